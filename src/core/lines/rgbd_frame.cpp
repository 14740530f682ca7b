#include "insitu_calibration/lines/rgbd_frame.h"

#include <cmath>
#include <string>

namespace insitu_calibration
{
namespace
{
std::string sizeString(int w, int h)
{
  return std::to_string(w) + "x" + std::to_string(h);
}
}  // namespace

Status RgbdCamera::validate() const
{
  const Intrinsics& k = intrinsics;
  if (!(std::isfinite(k.fx) && std::isfinite(k.fy) && k.fx > 0.0 && k.fy > 0.0))
    return Error(ErrorCode::kInvalidInput, "camera_info has a zero, negative or non-finite focal length (fx = " +
                                               std::to_string(k.fx) + ", fy = " + std::to_string(k.fy) + ")");
  if (!(std::isfinite(k.cx) && std::isfinite(k.cy) && std::isfinite(k.skew)))
    return Error(ErrorCode::kInvalidInput, "camera_info has a non-finite principal point or skew");
  for (double d : plumb_bob)
    if (!std::isfinite(d))
      return Error(ErrorCode::kInvalidInput, "camera_info has non-finite distortion coefficients");
  if (width <= 0 || height <= 0)
    return Error(ErrorCode::kInvalidInput, "camera_info has no image size (" + sizeString(width, height) + ")");
  return Success();
}

bool RgbdCamera::hasDistortion() const
{
  for (double d : plumb_bob)
    if (d != 0.0)
      return true;
  return false;
}

Eigen::Vector2d RgbdCamera::normalize(const Eigen::Vector2d& pixel) const
{
  const Intrinsics& k = intrinsics;
  const double yd = (pixel.y() - k.cy) / k.fy;
  const double xd = (pixel.x() - k.cx - k.skew * yd) / k.fx;
  if (!hasDistortion())
    return {xd, yd};
  const double k1 = plumb_bob[0], k2 = plumb_bob[1], p1 = plumb_bob[2], p2 = plumb_bob[3], k3 = plumb_bob[4];
  double x = xd, y = yd;
  for (int i = 0; i < 20; ++i)
  {
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    const double dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
    x = (xd - dx) / radial;
    y = (yd - dy) / radial;
  }
  return {x, y};
}

Status validateFrame(const RgbdFrame& frame)
{
  if (auto s = frame.camera.validate(); !s)
    return s;
  if (frame.rgb.empty())
    return Error(ErrorCode::kInvalidInput, "the RGB image is empty");
  if (frame.depth.empty())
    return Error(ErrorCode::kInvalidInput, "the depth image is empty");
  const int w = frame.camera.width, h = frame.camera.height;
  if (frame.rgb.cols != w || frame.rgb.rows != h)
    return Error(ErrorCode::kInvalidInput, "the RGB image is " + sizeString(frame.rgb.cols, frame.rgb.rows) +
                                               " but its camera_info says " + sizeString(w, h));
  if (frame.depth.cols != w || frame.depth.rows != h)
    return Error(ErrorCode::kInvalidInput, "the depth image is " + sizeString(frame.depth.cols, frame.depth.rows) +
                                               " but the RGB camera_info says " + sizeString(w, h) +
                                               " (depth must be registered to the RGB image)");
  if (frame.depth.type() != CV_16UC1 && frame.depth.type() != CV_32FC1)
    return Error(ErrorCode::kInvalidInput,
                 "depth must be 16UC1 (millimetres) or 32FC1 (metres), not " + cv::typeToString(frame.depth.type()));
  const Eigen::Matrix4d m = frame.T_map_camera.matrix();
  if (!m.allFinite())
    return Error(ErrorCode::kInvalidInput, "the camera pose is not finite");
  const Eigen::Matrix3d r = frame.T_map_camera.linear();
  if ((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() > 1e-4 || r.determinant() < 0.0)
    return Error(ErrorCode::kInvalidInput, "the camera pose's rotation is not a rotation matrix");
  return Success();
}

}  // namespace insitu_calibration
