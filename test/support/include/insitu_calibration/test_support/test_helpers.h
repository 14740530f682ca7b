// Shared helpers of the core unit tests.
#ifndef INSITU_CALIBRATION_TEST_SUPPORT_TEST_HELPERS_H
#define INSITU_CALIBRATION_TEST_SUPPORT_TEST_HELPERS_H

#include <cmath>

#include <Eigen/Geometry>

#include "insitu_calibration/camera/camera_model.h"

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

// An optical frame (z forward, x right, y down) at (x, y, height) looking horizontally towards yaw about world z.
inline Eigen::Isometry3d levelCameraPose(double x, double y, double yaw, double height = 1.2)
{
  Eigen::Matrix3d base_from_optical;
  base_from_optical.col(0) = -Eigen::Vector3d::UnitY();
  base_from_optical.col(1) = -Eigen::Vector3d::UnitZ();
  base_from_optical.col(2) = Eigen::Vector3d::UnitX();
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * base_from_optical;
  t.translation() = Eigen::Vector3d(x, y, height);
  return t;
}
}  // namespace test
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_TEST_SUPPORT_TEST_HELPERS_H
