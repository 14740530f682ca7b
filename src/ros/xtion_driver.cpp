#include "insitu_calibration/ros/xtion_driver.h"

#include <array>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include <boost/make_shared.hpp>
#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2/LinearMath/Quaternion.h>

#include "insitu_calibration/drivers/depth_cloud.h"
#include "insitu_calibration/ros/parameter_reader.h"

namespace insitu_calibration
{
namespace
{
using drivers::StreamKind;
using Clock = std::chrono::steady_clock;

// The fields of view the Xtion's PS1080 driver reports (radians), for devices and recordings that report none.
constexpr double kNominalColorHfov = 1.0226;
constexpr double kNominalColorVfov = 0.7966;
constexpr double kNominalDepthHfov = 1.0145;
constexpr double kNominalDepthVfov = 0.7898;

double secondsSince(Clock::time_point since)
{
  return std::chrono::duration<double>(Clock::now() - since).count();
}

std::string formatSeconds(double seconds)
{
  char text[32];
  std::snprintf(text, sizeof(text), "%.3g s", seconds);
  return text;
}

// Camera info from the core's pinhole matrices (drivers/depth_cloud.h) and back.
sensor_msgs::CameraInfo toCameraInfo(const drivers::PinholeMatrices& m)
{
  sensor_msgs::CameraInfo info;
  info.width = m.width;
  info.height = m.height;
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  std::copy(m.K.begin(), m.K.end(), info.K.begin());
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::copy(m.P.begin(), m.P.end(), info.P.begin());
  return info;
}

// A calibration made at another resolution of the same aspect ratio, scaled (drivers::scalePinhole).
bool scaleInfo(sensor_msgs::CameraInfo& info, int width, int height)
{
  drivers::PinholeMatrices m;
  m.width = static_cast<int>(info.width);
  m.height = static_cast<int>(info.height);
  std::copy(info.K.begin(), info.K.end(), m.K.begin());
  std::copy(info.P.begin(), info.P.end(), m.P.begin());
  if (!drivers::scalePinhole(m, width, height))
    return false;
  std::copy(m.K.begin(), m.K.end(), info.K.begin());
  std::copy(m.P.begin(), m.P.end(), info.P.begin());
  info.width = width;
  info.height = height;
  return true;
}
}  // namespace

XtionDriver::XtionDriver(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh), it_(nh) {}

XtionDriver::~XtionDriver()
{
  stop();
}

// Every parameter is checked (type, finiteness, range: README's xtion_node parameters) before the device opens.
Status XtionDriver::readParameters()
{
  using Range = ParameterRange;
  Parameters& p = params_;
  ParameterReader read(pnh_);
  p.device.uri = read.text("device_uri", "", true);
  for (const auto& [name, target] :
       {std::make_pair("color_mode", &p.device.color_mode), std::make_pair("depth_mode", &p.device.depth_mode)})
  {
    const Expected<drivers::VideoModeSpec> mode = drivers::parseVideoMode(read.text(name, "640x480@30", false));
    if (!mode)
      read.fail(std::string("parameter ~") + name + ": " + mode.error().message());
    else
      *target = *mode;
  }
  p.device.registration = read.flag("registration", true);
  p.device.sync = read.flag("sync", true);
  p.device.oni_loop = read.flag("oni_loop", true);
  p.device.oni_speed = read.number("oni_speed", 1.0, Range::positive(100.0));  // 1 = as recorded
  p.retry_period_s = read.number("retry_period", 2.0, Range::closed(0.1, 3600.0, "s"));
  p.frame_timeout_s = read.number("frame_timeout", 3.0, Range::positive(3600.0, "s"));
  p.fault_report_period_s = read.number("fault_report_period", 30.0, Range::closed(0.0, 86400.0, "s"));
  p.publish_points = read.flag("publish_points", false);
  p.publish_tf = read.flag("publish_tf", true);
  p.camera_link_frame_id = read.text("camera_link_frame_id", "camera_link", false);
  p.rgb_frame_id = read.text("rgb_frame_id", "camera_rgb_optical_frame", false);
  p.depth_frame_id = read.text("depth_frame_id", "camera_depth_optical_frame", false);
  // [x, y, z] in metres in camera_link.
  p.rgb_xyz = read.numbers("rgb_xyz", p.rgb_xyz, 3, Range::closed(-1.0, 1.0, "m"));
  p.depth_xyz = read.numbers("depth_xyz", p.depth_xyz, 3, Range::closed(-1.0, 1.0, "m"));
  p.rgb_camera_info_url = read.text("rgb_camera_info_url", "", true);
  p.depth_camera_info_url = read.text("depth_camera_info_url", "", true);
  const double min_timeout = 2.0 / std::min(p.device.color_mode.fps, p.device.depth_mode.fps);
  if (read.ok() && p.frame_timeout_s < min_timeout)
    read.fail("parameter ~frame_timeout is " + formatParameterValue(p.frame_timeout_s) +
              ", allowed: at least two frame periods (" + formatSeconds(min_timeout) + ")");
  if (!read.ok())
    return Error(ErrorCode::kInvalidInput, read.summary());
  return Success{};
}

Status XtionDriver::start()
{
  if (running_)
    return Success{};
  const Status read = readParameters();
  if (!read)
    return read;
  rgb_pub_ = it_.advertiseCamera("rgb/image_raw", 1);
  depth_pub_ = it_.advertiseCamera("depth_registered/image_raw", 1);
  if (params_.publish_points)
    points_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("depth_registered/points", 1);
  rgb_info_manager_.reset(new camera_info_manager::CameraInfoManager(ros::NodeHandle(nh_, "rgb"), "rgb_camera",
                                                                     params_.rgb_camera_info_url));
  depth_info_manager_.reset(new camera_info_manager::CameraInfoManager(ros::NodeHandle(nh_, "depth"), "depth_camera",
                                                                       params_.depth_camera_info_url));
  if (params_.publish_tf)
    publishStaticTransforms();
  running_ = true;
  worker_ = std::thread(&XtionDriver::run, this);
  return Success{};
}

void XtionDriver::stop()
{
  if (worker_.joinable())
  {
    {
      std::lock_guard<std::mutex> lock(wait_mutex_);
      running_ = false;
    }
    wake_.notify_all();
    worker_.join();
  }
  running_ = false;
  device_.close();
}

void XtionDriver::publishStaticTransforms()
{
  tf2::Quaternion optical;
  optical.setRPY(-M_PI / 2, 0.0, -M_PI / 2);  // camera_link (x forward, z up) -> optical (z forward, y down)
  std::vector<geometry_msgs::TransformStamped> transforms;
  for (const auto& [child, xyz] : {std::make_pair(params_.rgb_frame_id, params_.rgb_xyz),
                                   std::make_pair(params_.depth_frame_id, params_.depth_xyz)})
  {
    geometry_msgs::TransformStamped t;
    t.header.stamp = ros::Time::now();
    t.header.frame_id = params_.camera_link_frame_id;
    t.child_frame_id = child;
    t.transform.translation.x = xyz[0];
    t.transform.translation.y = xyz[1];
    t.transform.translation.z = xyz[2];
    t.transform.rotation.x = optical.x();
    t.transform.rotation.y = optical.y();
    t.transform.rotation.z = optical.z();
    t.transform.rotation.w = optical.w();
    transforms.push_back(t);
  }
  static_tf_.sendTransform(transforms);
}

void XtionDriver::waitFor(double seconds)
{
  std::unique_lock<std::mutex> lock(wait_mutex_);
  wake_.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return !running_; });
}

void XtionDriver::reportFault(const std::string& message)
{
  const auto now = Clock::now();
  const std::string retry = " Retrying every " + formatSeconds(params_.retry_period_s) + ".";
  if (!in_fault_)
  {
    in_fault_ = true;
    fault_since_ = now;
    fault_attempts_ = 0;
  }
  ++fault_attempts_;
  if (message != last_fault_)
  {
    ROS_ERROR_STREAM("xtion_node: " << message << retry);
    last_fault_ = message;
    last_fault_report_ = now;
  }
  else if (std::chrono::duration<double>(now - last_fault_report_).count() >= params_.fault_report_period_s)
  {
    ROS_WARN_STREAM("xtion_node: still failing after " << fault_attempts_ << " attempts in "
                                                       << formatSeconds(secondsSince(fault_since_)) << ": " << message
                                                       << retry);
    last_fault_report_ = now;
  }
}

void XtionDriver::reportRecovered()
{
  if (!in_fault_)
    return;
  ROS_INFO_STREAM("xtion_node: publishing again after " << formatSeconds(secondsSince(fault_since_)) << " and "
                                                        << fault_attempts_ << " failed attempts");
  in_fault_ = false;
  last_fault_.clear();
}

void XtionDriver::onOpened()
{
  const drivers::DeviceSummary& s = device_.summary();
  ROS_INFO_STREAM("xtion_node: opened " << s.describe());
  stamper_ = drivers::FrameStamper(s.sync_on, std::max(s.color_mode.fps, s.depth_mode.fps));
  last_color_.reset();
  last_frame_time_ = Clock::now();
  // Facts about the device: said once, not at every reconnection.
  if (params_.device.registration && !s.registration_on && !warned_registration_)
  {
    warned_registration_ = true;
    ROS_WARN_STREAM("xtion_node: " << (s.is_file ? "the recording" : "the device")
                                   << " has no hardware depth-to-colour registration: depth_registered/image_raw is "
                                      "the raw depth image, in frame "
                                   << params_.depth_frame_id << ", not aligned with the colour image.");
  }
  if (params_.device.sync && !s.sync_on && !warned_sync_)
  {
    warned_sync_ = true;
    ROS_WARN(
        "xtion_node: the device refused colour/depth frame synchronisation: colour and depth get their own "
        "stamps.");
  }
  if (s.is_file && !warned_modes_ &&
      (s.color_mode != params_.device.color_mode || s.depth_mode != params_.device.depth_mode))
  {
    warned_modes_ = true;
    ROS_INFO_STREAM("xtion_node: playing the recording's modes (colour "
                    << s.color_mode.toString() << ", depth " << s.depth_mode.toString()
                    << "); color_mode and depth_mode apply to devices only.");
  }
  if (!warned_fov_ && (s.color_hfov <= 0.0 || s.depth_hfov <= 0.0))
  {
    warned_fov_ = true;
    ROS_INFO(
        "xtion_node: the device reports no field of view: without a camera_info URL, camera_info uses the "
        "Xtion's nominal fields of view.");
  }
  if (!s.serial.empty())
  {
    // Calibration files named after the device, as openni2_camera names them.
    rgb_info_manager_->setCameraName("rgb_" + s.serial);
    depth_info_manager_->setCameraName("depth_" + s.serial);
    rgb_info_manager_->loadCameraInfo(params_.rgb_camera_info_url);
    depth_info_manager_->loadCameraInfo(params_.depth_camera_info_url);
  }
  for (const auto& [url, manager] : {std::make_pair(params_.rgb_camera_info_url, rgb_info_manager_.get()),
                                     std::make_pair(params_.depth_camera_info_url, depth_info_manager_.get())})
    if (!url.empty() && !manager->isCalibrated())
      ROS_WARN_STREAM("xtion_node: the camera_info URL " << url
                                                         << " gave no calibration (see the camera_info_manager "
                                                            "messages above): using the field of view instead.");
}

void XtionDriver::run()
{
  while (running_)
  {
    if (!device_.isOpen())
    {
      const Status opened = device_.open(params_.device);
      if (!opened)
      {
        reportFault(opened.error().message());
        waitFor(params_.retry_period_s);
        continue;
      }
      onOpened();
    }
    const Expected<bool> read = device_.readFrame(100, [this](const drivers::FrameView& frame) { onFrame(frame); });
    if (!read)
    {
      reportFault(read.error().message() + ". Closed it; plug it back in.");
      device_.close();
      waitFor(params_.retry_period_s);
      continue;
    }
    if (*read)
    {
      last_frame_time_ = Clock::now();
      reportRecovered();
    }
    else if (secondsSince(last_frame_time_) > params_.frame_timeout_s)
    {
      const drivers::DeviceSummary& s = device_.summary();
      reportFault("no frame from " + s.uri + " for " + formatSeconds(params_.frame_timeout_s) +
                  (s.is_file ? ": the recording ended (set ~oni_loop true to play it in a loop)"
                             : ": the device stopped sending (unplugged? check its USB cable and power)") +
                  ". Closed it.");
      device_.close();
      waitFor(params_.retry_period_s);
    }
  }
  device_.close();
}

sensor_msgs::CameraInfo XtionDriver::cameraInfo(StreamKind kind, int width, int height)
{
  const drivers::DeviceSummary& s = device_.summary();
  // Registered depth is in the colour camera: it shares the colour camera's model.
  const StreamKind model = (kind == StreamKind::kDepth && s.registration_on) ? StreamKind::kColor : kind;
  camera_info_manager::CameraInfoManager* manager =
      model == StreamKind::kColor ? rgb_info_manager_.get() : depth_info_manager_.get();
  if (manager->isCalibrated())
  {
    sensor_msgs::CameraInfo info = manager->getCameraInfo();
    if (static_cast<int>(info.width) == width && static_cast<int>(info.height) == height)
      return info;
    const int w0 = info.width;
    const int h0 = info.height;
    if (scaleInfo(info, width, height))
      return info;
    bool& warned = warned_info_size_[model == StreamKind::kColor ? 0 : 1];
    if (!warned)
    {
      warned = true;
      ROS_WARN(
          "xtion_node: the %s calibration is for %dx%d, the images are %dx%d (another aspect ratio): using the "
          "field of view. Calibrate at this mode.",
          drivers::toString(model), w0, h0, width, height);
    }
  }
  double hfov = model == StreamKind::kColor ? s.color_hfov : s.depth_hfov;
  double vfov = model == StreamKind::kColor ? s.color_vfov : s.depth_vfov;
  if (!(hfov > 0.0 && vfov > 0.0))
  {
    hfov = model == StreamKind::kColor ? kNominalColorHfov : kNominalDepthHfov;
    vfov = model == StreamKind::kColor ? kNominalColorVfov : kNominalDepthVfov;
  }
  return toCameraInfo(drivers::pinholeFromFieldOfView(width, height, hfov, vfov));
}

void XtionDriver::onFrame(const drivers::FrameView& frame)
{
  const ros::Time stamp(stamper_.stamp(frame.stream, frame.device_time_us, ros::Time::now().toSec()));
  const bool points = params_.publish_points && points_pub_.getNumSubscribers() > 0;
  const bool color = frame.stream == StreamKind::kColor;
  const image_transport::CameraPublisher& pub = color ? rgb_pub_ : depth_pub_;
  const bool registered = device_.summary().registration_on;
  if (pub.getNumSubscribers() == 0 && !points)
    return;  // nobody listens: no copy, no message

  auto image = boost::make_shared<sensor_msgs::Image>();
  image->header.stamp = stamp;
  image->header.frame_id = (color || registered) ? params_.rgb_frame_id : params_.depth_frame_id;
  image->width = frame.width;
  image->height = frame.height;
  image->encoding = color ? sensor_msgs::image_encodings::RGB8 : sensor_msgs::image_encodings::TYPE_16UC1;
  image->is_bigendian = 0;
  image->step = frame.width * (color ? 3 : 2);
  image->data.resize(static_cast<size_t>(image->step) * frame.height);
  if (frame.stride_bytes == image->step)
    std::memcpy(image->data.data(), frame.data, image->data.size());
  else
    for (int y = 0; y < frame.height; ++y)
      std::memcpy(&image->data[static_cast<size_t>(y) * image->step], frame.data + y * frame.stride_bytes, image->step);

  auto info = boost::make_shared<sensor_msgs::CameraInfo>(cameraInfo(frame.stream, frame.width, frame.height));
  info->header = image->header;
  if (pub.getNumSubscribers() > 0)
    pub.publish(image, info);
  if (color && points)
    last_color_ = image;
  else if (!color && points)
    publishPoints(image, *info);
}

void XtionDriver::publishPoints(const sensor_msgs::ImageConstPtr& depth, const sensor_msgs::CameraInfo& info)
{
  auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
  cloud->header = depth->header;
  cloud->height = depth->height;
  cloud->width = depth->width;
  cloud->is_dense = false;
  cloud->is_bigendian = false;
  sensor_msgs::PointCloud2Modifier modifier(*cloud);
  modifier.setPointCloud2FieldsByString(2, "xyz", "rgb");  // pcl::PointXYZRGB's layout
  modifier.resize(static_cast<size_t>(depth->width) * depth->height);
  cloud->height = depth->height;
  cloud->width = depth->width;
  cloud->row_step = cloud->point_step * cloud->width;

  // Colours only where depth is registered to the colour image (else the pixels do not correspond).
  const sensor_msgs::Image* color = (device_.summary().registration_on && last_color_) ? last_color_.get() : nullptr;
  const drivers::DepthImageView depth_view{depth->data.data(), static_cast<int>(depth->width),
                                           static_cast<int>(depth->height), depth->step};
  drivers::RgbImageView color_view;
  if (color != nullptr)
    color_view = {color->data.data(), static_cast<int>(color->width), static_cast<int>(color->height), color->step};
  const drivers::PointLayout layout{cloud->point_step, cloud->fields[0].offset, cloud->fields[1].offset,
                                    cloud->fields[2].offset, cloud->fields[3].offset};
  std::array<double, 9> K;
  std::copy(info.K.begin(), info.K.end(), K.begin());
  drivers::depthToPoints(depth_view, color != nullptr ? &color_view : nullptr, K, layout, cloud->data.data());
  points_pub_.publish(cloud);
}

}  // namespace insitu_calibration
