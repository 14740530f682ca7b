#include "insitu_calibration/ros/conversions.h"

#include <cmath>

#include <sensor_msgs/image_encodings.h>

#include <cv_bridge/cv_bridge.h>
#include <tf2_eigen/tf2_eigen.h>

#include "insitu_calibration/geometry/optical_frame.h"

namespace insitu_calibration
{
Eigen::Quaterniond bodyFromOptical()
{
  return Eigen::Quaterniond(bodyFromOpticalRotation());
}

sensor_msgs::CameraInfo toCameraInfo(const CalibrationFile& calibration, const std::string& optical_frame)
{
  sensor_msgs::CameraInfo info;
  info.header.frame_id = optical_frame;
  info.width = static_cast<uint32_t>(calibration.image_width);
  info.height = static_cast<uint32_t>(calibration.image_height);
  const Eigen::Matrix3d k = calibration.camera.intrinsics().matrix();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
    {
      info.K[3 * r + c] = k(r, c);
      info.R[3 * r + c] = r == c ? 1.0 : 0.0;
      info.P[4 * r + c] = k(r, c);
    }
  info.distortion_model = "plumb_bob";
  info.D.assign(calibration.plumb_bob.coefficients.begin(), calibration.plumb_bob.coefficients.end());
  return info;
}

std::vector<geometry_msgs::TransformStamped> cameraTransforms(const CalibrationFile& calibration,
                                                              const std::string& world_frame,
                                                              const std::string& link_frame,
                                                              const std::string& optical_frame, const ros::Time& stamp)
{
  const Eigen::Isometry3d world_from_optical = calibration.camera.pose().worldFromCamera();
  Eigen::Isometry3d link_from_optical = Eigen::Isometry3d::Identity();
  link_from_optical.linear() = bodyFromOptical().toRotationMatrix();
  const Eigen::Isometry3d world_from_link = world_from_optical * link_from_optical.inverse();

  geometry_msgs::TransformStamped link = tf2::eigenToTransform(world_from_link);
  link.header.stamp = stamp;
  link.header.frame_id = world_frame;
  link.child_frame_id = link_frame;
  geometry_msgs::TransformStamped optical = tf2::eigenToTransform(link_from_optical);
  optical.header.stamp = stamp;
  optical.header.frame_id = link_frame;
  optical.child_frame_id = optical_frame;
  return {link, optical};
}

insitu_calibration::CalibrationResult toResultMsg(const CalibrationFile& file, const CameraCalibration* result,
                                                  const std::string& world_frame)
{
  insitu_calibration::CalibrationResult msg;
  msg.camera_name = file.camera_name;
  msg.success = true;
  msg.image_width = static_cast<uint32_t>(file.image_width);
  msg.image_height = static_cast<uint32_t>(file.image_height);
  const Eigen::Matrix3d k = file.camera.intrinsics().matrix();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      msg.K[3 * r + c] = k(r, c);
  msg.division_lambda = file.camera.distortion().lambda;
  msg.division_center[0] = file.camera.distortion().center.x();
  msg.division_center[1] = file.camera.distortion().center.y();
  msg.distortion_model = "plumb_bob";
  msg.D.assign(file.plumb_bob.coefficients.begin(), file.plumb_bob.coefficients.end());
  msg.plumb_bob_max_error_px = file.plumb_bob.max_error_px;
  msg.pose.header.frame_id = world_frame;
  msg.pose.pose = tf2::toMsg(file.camera.pose().worldFromCamera());
  if (file.quality)
  {
    msg.rms_px = file.quality->rms_px;
    msg.median_px = file.quality->median_px;
    msg.lines = static_cast<uint32_t>(file.quality->lines);
    msg.points = static_cast<uint32_t>(file.quality->points);
    msg.constraints = static_cast<uint32_t>(file.quality->constraints);
  }
  if (result)
  {
    msg.iterations = static_cast<uint32_t>(result->iterations);
    msg.converged = result->converged;
    msg.inlier_lines = static_cast<uint32_t>(result->inlier_count);
    const CameraUncertainty& u = result->uncertainty;
    msg.uncertainty_available = u.available;
    msg.uncertainty_note = u.available ? "" : u.reason;
    msg.sigma_fx_px = u.fx;
    msg.sigma_fy_px = u.fy;
    msg.sigma_cx_px = u.cx;
    msg.sigma_cy_px = u.cy;
    msg.sigma_lambda = u.lambda;
    msg.sigma_position_m = u.position_m;
    msg.sigma_rotation_deg = u.rotation_deg;
  }
  else
  {
    // A calibration loaded from its file: what the file kept.
    msg.converged = file.quality && file.quality->extra.count("converged") && file.quality->extra.at("converged") > 0;
    const auto extra = [&](const char* key) {
      return file.quality && file.quality->extra.count(key) ? file.quality->extra.at(key) : 0.0;
    };
    msg.iterations = static_cast<uint32_t>(extra("iterations"));
    msg.inlier_lines = static_cast<uint32_t>(extra("inlier_lines"));
    msg.uncertainty_available = extra("sigma_fx_px") > 0.0;
    msg.uncertainty_note = msg.uncertainty_available ? "" : "not kept in the loaded file";
    msg.sigma_fx_px = extra("sigma_fx_px");
    msg.sigma_fy_px = extra("sigma_fy_px");
    msg.sigma_cx_px = extra("sigma_cx_px");
    msg.sigma_cy_px = extra("sigma_cy_px");
    msg.sigma_lambda = extra("sigma_lambda");
    msg.sigma_position_m = extra("sigma_position_m");
    msg.sigma_rotation_deg = extra("sigma_rotation_deg");
  }
  return msg;
}

Eigen::Isometry3d toEigen(const geometry_msgs::Transform& transform)
{
  return tf2::transformToEigen(transform);
}

namespace
{
// A message whose header does not match its data would make cv_bridge read past the data or OpenCV assert: checked
// before either sees it. Sides up to 32768 px.
Status checkImageMessage(const sensor_msgs::Image& image, const char* what)
{
  size_t bytes_per_pixel = 0;
  try
  {
    bytes_per_pixel = static_cast<size_t>(sensor_msgs::image_encodings::numChannels(image.encoding)) *
                      static_cast<size_t>(sensor_msgs::image_encodings::bitDepth(image.encoding) / 8);
  }
  catch (const std::exception&)
  {
    return Error(ErrorCode::kInvalidInput, std::string(what) + ": unknown encoding '" + image.encoding + "'");
  }
  const size_t width = image.width, height = image.height, step = image.step;
  if (width == 0 || height == 0 || width > 32768 || height > 32768 || bytes_per_pixel == 0 ||
      step < width * bytes_per_pixel || image.data.size() < step * height)
    return Error(ErrorCode::kInvalidInput, std::string(what) + ": a " + std::to_string(width) + "x" +
                                               std::to_string(height) + " " + image.encoding + " image with step " +
                                               std::to_string(step) + " and " + std::to_string(image.data.size()) +
                                               " bytes is inconsistent");
  return Success{};
}
}  // namespace

Expected<RgbdFrame> toRgbdFrame(const sensor_msgs::Image& rgb, const sensor_msgs::Image& depth,
                                const sensor_msgs::CameraInfo& info, const Eigen::Isometry3d& T_map_camera)
{
  RgbdFrame frame;
  for (const Status& s : {checkImageMessage(rgb, "RGB image"), checkImageMessage(depth, "depth image")})
    if (!s)
      return s.error();
  try
  {
    // Copies: the frame outlives the messages in offline use.
    frame.rgb = cv_bridge::toCvCopy(rgb, "bgr8")->image;
    frame.depth = cv_bridge::toCvCopy(depth)->image;
  }
  catch (const std::exception& e)  // cv_bridge's and OpenCV's
  {
    return Error(ErrorCode::kInvalidInput, std::string("cannot convert the RGB-D images: ") + e.what());
  }
  frame.camera.width = static_cast<int>(info.width);
  frame.camera.height = static_cast<int>(info.height);
  frame.camera.intrinsics =
      Intrinsics::fromMatrix(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(info.K.data()));
  const Intrinsics& in = frame.camera.intrinsics;
  if (!(in.fx > 0.0 && in.fy > 0.0 && std::isfinite(in.fx) && std::isfinite(in.fy) && std::isfinite(in.cx) &&
        std::isfinite(in.cy) && std::isfinite(in.skew)) ||
      frame.camera.width != frame.rgb.cols || frame.camera.height != frame.rgb.rows)
    return Error(ErrorCode::kInvalidInput,
                 "the RGB camera_info has no usable K (zeros or NaN) or another size than "
                 "its image");
  if (!T_map_camera.matrix().allFinite())
    return Error(ErrorCode::kInvalidInput, "the camera's pose in the map holds NaN or infinite values");
  if (info.distortion_model == "plumb_bob" && info.D.size() >= 5)
    for (int i = 0; i < 5; ++i)
      frame.camera.plumb_bob[i] = info.D[i];
  frame.T_map_camera = T_map_camera;
  frame.stamp = rgb.header.stamp.toSec();
  return frame;
}

Expected<cv::Mat> toGrey(const sensor_msgs::Image& image)
{
  if (const Status s = checkImageMessage(image, "cannot convert the image to grey"); !s)
    return s.error();
  try
  {
    return cv_bridge::toCvCopy(image, "mono8")->image;
  }
  catch (const std::exception& e)  // cv_bridge's and OpenCV's
  {
    return Error(ErrorCode::kInvalidInput, std::string("cannot convert the image to grey: ") + e.what());
  }
}

geometry_msgs::Point toPointMsg(const Eigen::Vector3d& point)
{
  geometry_msgs::Point out;
  out.x = point.x();
  out.y = point.y();
  out.z = point.z();
  return out;
}

}  // namespace insitu_calibration
