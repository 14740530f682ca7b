// Shared helpers of the core unit tests.
#ifndef INSITU_CALIBRATION_TEST_SUPPORT_TEST_HELPERS_H
#define INSITU_CALIBRATION_TEST_SUPPORT_TEST_HELPERS_H

#include <cmath>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/lines/depth_sampler.h"
#include "insitu_calibration/lines/rgbd_frame.h"

namespace insitu_calibration
{
namespace test
{
// Relative difference of two projection matrices up to scale and sign.
inline double projectionDifference(const Matrix34d& a, const Matrix34d& b)
{
  const Matrix34d na = a / a.norm();
  const Matrix34d nb = b / b.norm();
  return std::min((na - nb).norm(), (na + nb).norm());
}

// |lambda_a - lambda_b| relative to |lambda_b|, or scaled by r^2 at the image corner when lambda_b = 0 (the
// displacement fraction the difference makes there).
inline double lambdaDifference(double a, double b, double corner_radius_px)
{
  if (b != 0.0)
    return std::abs(a - b) / std::abs(b);
  return std::abs(a - b) * corner_radius_px * corner_radius_px;
}

// An optical frame (z forward, x right, y down) at (x, y, height) looking towards yaw about world z, tilted down by
// tilt_down_deg.
inline Eigen::Isometry3d tiltedCameraPose(double x, double y, double yaw, double tilt_down_deg, double height)
{
  Eigen::Matrix3d base_from_optical;
  base_from_optical.col(0) = -Eigen::Vector3d::UnitY();
  base_from_optical.col(1) = -Eigen::Vector3d::UnitZ();
  base_from_optical.col(2) = Eigen::Vector3d::UnitX();
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
               Eigen::AngleAxisd(tilt_down_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix() *
               base_from_optical;
  t.translation() = Eigen::Vector3d(x, y, height);
  return t;
}

// The same looking horizontally.
inline Eigen::Isometry3d levelCameraPose(double x, double y, double yaw, double height = 1.2)
{
  return tiltedCameraPose(x, y, yaw, 0.0, height);
}

// The Xtion's RGB camera: 640 x 480, principal point at the centre (the simulator's focal length by default).
inline RgbdCamera xtionRgbdCamera(double focal_px = 570.0)
{
  RgbdCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.intrinsics.fx = camera.intrinsics.fy = focal_px;
  camera.intrinsics.cx = 319.5;
  camera.intrinsics.cy = 239.5;
  return camera;
}

// Depth samples along the image of the floor line x = x_ahead (world frame, y from -1 to 1 m) seen by the Xtion at
// T_map_camera: with the floor's depth, and with depth nearer_m nearer (an edge above the floor).
inline std::pair<std::vector<DepthSample>, std::vector<DepthSample>> floorLineDepthSamples(
    const Eigen::Isometry3d& T_map_camera, double x_ahead, double nearer_m)
{
  const RgbdCamera camera = xtionRgbdCamera();
  std::vector<DepthSample> on_floor, nearer;
  for (double y = -1.0; y <= 1.0; y += 0.1)
  {
    const Eigen::Vector3d p = T_map_camera.inverse() * Eigen::Vector3d(x_ahead, y, 0.0);
    DepthSample s;
    s.pixel = Eigen::Vector2d(camera.intrinsics.fx * p.x() / p.z() + camera.intrinsics.cx,
                              camera.intrinsics.fy * p.y() / p.z() + camera.intrinsics.cy);
    s.depth_m = p.z();
    on_floor.push_back(s);
    s.depth_m = p.z() - nearer_m;
    nearer.push_back(s);
  }
  return {on_floor, nearer};
}
}  // namespace test
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_TEST_SUPPORT_TEST_HELPERS_H
