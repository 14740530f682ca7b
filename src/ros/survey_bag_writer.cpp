#include "insitu_calibration/ros/survey_bag_writer.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <memory>

#include <boost/make_shared.hpp>
#include <geometry_msgs/TransformStamped.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

namespace insitu_calibration
{
namespace sim = simulation;

const char* const kXtionRgbImageTopic = "/camera/rgb/image_raw";
const char* const kXtionRgbInfoTopic = "/camera/rgb/camera_info";
const char* const kXtionDepthImageTopic = "/camera/depth_registered/image_raw";
const char* const kXtionDepthInfoTopic = "/camera/depth_registered/camera_info";
const char* const kXtionOpticalFrame = "camera_rgb_optical_frame";

std::string fixedImageTopic(const std::string& camera)
{
  return "/fixed/" + camera + "/image_raw";
}
std::string fixedInfoTopic(const std::string& camera)
{
  return "/fixed/" + camera + "/camera_info";
}
std::string fixedOpticalFrame(const std::string& camera)
{
  return camera + "_optical_frame";
}

std::vector<std::string> surveyTopics(const sim::World& world)
{
  std::vector<std::string> topics{
      kXtionRgbImageTopic, kXtionRgbInfoTopic, kXtionDepthImageTopic, kXtionDepthInfoTopic, "/tf", "/tf_static"};
  for (const auto& c : world.fixed_cameras)
  {
    topics.push_back(fixedImageTopic(c.name));
    topics.push_back(fixedInfoTopic(c.name));
  }
  std::sort(topics.begin(), topics.end());
  return topics;
}

sensor_msgs::CameraInfo xtionCameraInfo(const sim::XtionConfig& xtion)
{
  sensor_msgs::CameraInfo info;
  info.header.frame_id = kXtionOpticalFrame;
  info.width = xtion.width;
  info.height = xtion.height;
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  const Intrinsics& k = xtion.intrinsics;
  info.K = {k.fx, k.skew, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0};
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  info.P = {k.fx, k.skew, k.cx, 0.0, 0.0, k.fy, k.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

sensor_msgs::CameraInfo nominalCameraInfo(int width, int height)
{
  sensor_msgs::CameraInfo info;
  info.width = width;
  info.height = height;
  return info;  // K, R, P zero, no distortion model: not calibrated
}

namespace
{
using Clock = std::chrono::steady_clock;

sensor_msgs::Image toImage(const cv::Mat& mat, const std::string& encoding, const std::string& frame,
                           const ros::Time& stamp)
{
  sensor_msgs::Image image;
  image.header.stamp = stamp;
  image.header.frame_id = frame;
  image.height = mat.rows;
  image.width = mat.cols;
  image.encoding = encoding;
  image.is_bigendian = 0;
  image.step = static_cast<uint32_t>(mat.cols * mat.elemSize());
  image.data.resize(static_cast<size_t>(image.step) * mat.rows);
  for (int y = 0; y < mat.rows; ++y)
    std::memcpy(&image.data[static_cast<size_t>(y) * image.step], mat.ptr(y), image.step);
  return image;
}

tf2_msgs::TFMessage toTf(const std::vector<sim::NamedTransform>& transforms, const ros::Time& stamp)
{
  tf2_msgs::TFMessage msg;
  for (const auto& t : transforms)
  {
    geometry_msgs::TransformStamped ts = tf2::eigenToTransform(t.transform);
    ts.header.stamp = stamp;
    ts.header.frame_id = t.parent;
    ts.child_frame_id = t.child;
    msg.transforms.push_back(ts);
  }
  return msg;
}

// A header that marks /tf_static latched, as static_transform_publisher's.
boost::shared_ptr<ros::M_string> latchedTfHeader()
{
  auto latched = boost::make_shared<ros::M_string>();
  (*latched)["callerid"] = "/camera_base_link";
  (*latched)["latching"] = "1";
  (*latched)["type"] = ros::message_traits::datatype<tf2_msgs::TFMessage>();
  (*latched)["md5sum"] = ros::message_traits::md5sum<tf2_msgs::TFMessage>();
  (*latched)["message_definition"] = ros::message_traits::definition<tf2_msgs::TFMessage>();
  return latched;
}

// Writes the simulator's events into an open bag as the robot's drivers would publish them; counts messages and the
// time spent writing (as opposed to rendering).
class SurveyEventWriter
{
public:
  SurveyEventWriter(const sim::SurveySimulator& survey, rosbag::Bag& bag, SurveyBagSummary* summary, double* write_s)
      : survey_(survey),
        bag_(bag),
        summary_(summary),
        write_s_(write_s),
        xtion_info_(xtionCameraInfo(survey.world().xtion)),
        latched_(latchedTfHeader())
  {
    for (const auto& c : survey.world().fixed_cameras)
    {
      fixed_info_.push_back(nominalCameraInfo(c.width, c.height));
      fixed_info_.back().header.frame_id = fixedOpticalFrame(c.name);
    }
  }

  void write(const sim::SurveyEvent& e, const std::function<void(size_t, size_t)>& progress)
  {
    ros::Time stamp;
    stamp.fromNSec(static_cast<uint64_t>(survey_.options().start_time_ns + e.stamp_ns));
    switch (e.kind)
    {
      case sim::SurveyEventKind::kStaticTf:
        timed([&] { bag_.write("/tf_static", stamp, toTf(survey_.staticTransforms(), stamp), latched_); });
        ++summary_->messages;
        break;
      case sim::SurveyEventKind::kTf:
        timed([&] { bag_.write("/tf", stamp, toTf(survey_.dynamicTransforms(e.stamp_ns), stamp)); });
        ++summary_->messages;
        break;
      case sim::SurveyEventKind::kXtion:
        writeXtion(survey_.xtionFrame(e.index), stamp);
        if (progress)
          progress(++frames_, survey_.xtionFrameCount());
        break;
      case sim::SurveyEventKind::kFixed:
        writeFixed(e.camera, survey_.fixedFrame(e.camera, e.index), stamp);
        break;
    }
  }

private:
  template <typename Write>
  void timed(Write&& write)
  {
    const auto t0 = Clock::now();
    write();
    *write_s_ += std::chrono::duration<double>(Clock::now() - t0).count();
  }

  void writeXtion(const sim::XtionFrame& f, const ros::Time& stamp)
  {
    timed([&] {
      sensor_msgs::CameraInfo info = xtion_info_;
      info.header.stamp = stamp;
      bag_.write(kXtionRgbImageTopic, stamp,
                 toImage(f.rgb, sensor_msgs::image_encodings::RGB8, kXtionOpticalFrame, stamp));
      bag_.write(kXtionRgbInfoTopic, stamp, info);
      bag_.write(kXtionDepthImageTopic, stamp,
                 toImage(f.depth_mm, sensor_msgs::image_encodings::TYPE_16UC1, kXtionOpticalFrame, stamp));
      bag_.write(kXtionDepthInfoTopic, stamp, info);
    });
    summary_->messages += 4;
  }

  void writeFixed(int camera, const sim::FixedFrame& f, const ros::Time& stamp)
  {
    timed([&] {
      const std::string& name = survey_.world().fixed_cameras[camera].name;
      sensor_msgs::CameraInfo info = fixed_info_[camera];
      info.header.stamp = stamp;
      bag_.write(fixedImageTopic(name), stamp,
                 toImage(f.image, sensor_msgs::image_encodings::RGB8, fixedOpticalFrame(name), stamp));
      bag_.write(fixedInfoTopic(name), stamp, info);
    });
    summary_->messages += 2;
  }

  const sim::SurveySimulator& survey_;
  rosbag::Bag& bag_;
  SurveyBagSummary* summary_;
  double* write_s_;
  const sensor_msgs::CameraInfo xtion_info_;
  std::vector<sensor_msgs::CameraInfo> fixed_info_;
  const boost::shared_ptr<ros::M_string> latched_;
  size_t frames_ = 0;
};
}  // namespace

Expected<SurveyBagSummary> writeSurveyBag(const sim::SurveySimulator& survey, const std::string& path,
                                          const std::function<void(size_t, size_t)>& progress)
{
  const auto start = Clock::now();
  const std::string active = path + ".active";
  SurveyBagSummary summary;
  double write_s = 0.0;
  // A bag whose write failed (a full disk) is not destroyed: rosbag::Bag's destructor closes it, which writes
  // again and throws, and a destructor that throws ends the program. Its handle is left open instead.
  auto bag = std::make_unique<rosbag::Bag>();
  try
  {
    bag->open(active, rosbag::bagmode::Write);
    bag->setCompression(rosbag::compression::LZ4);
    SurveyEventWriter writer(survey, *bag, &summary, &write_s);
    for (const sim::SurveyEvent& e : survey.events())
      writer.write(e, progress);
    const auto t0 = Clock::now();
    bag->close();
    write_s += std::chrono::duration<double>(Clock::now() - t0).count();
  }
  catch (const std::exception& e)  // rosbag's, and cv::Exception or bad_alloc from a frame: no .active is left
  {
    bag.release();  // NOLINT(bugprone-unused-return-value): deliberately not destroyed (above)
    std::error_code ignored;
    std::filesystem::remove(active, ignored);
    return Error(ErrorCode::kIoError, "cannot write " + path + ": " + e.what() + " (is the disk full?)");
  }
  std::error_code ec;
  std::filesystem::rename(active, path, ec);
  if (ec)
    return Error(ErrorCode::kIoError, "cannot rename " + active + " to " + path + ": " + ec.message());
  summary.bytes = std::filesystem::file_size(path, ec);
  summary.bag_write_s = write_s;
  summary.total_s = std::chrono::duration<double>(Clock::now() - start).count();
  return summary;
}

}  // namespace insitu_calibration
