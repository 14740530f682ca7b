#include "insitu_calibration/camera/camera_model.h"

#include <algorithm>
#include <cmath>

namespace insitu_calibration
{
Eigen::Matrix3d Intrinsics::matrix() const
{
  Eigen::Matrix3d k;
  k << fx, skew, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
  return k;
}

Intrinsics Intrinsics::fromMatrix(const Eigen::Matrix3d& k)
{
  const Eigen::Matrix3d n = k / k(2, 2);
  Intrinsics in;
  in.fx = n(0, 0);
  in.fy = n(1, 1);
  in.skew = n(0, 1);
  in.cx = n(0, 2);
  in.cy = n(1, 2);
  return in;
}

std::optional<Eigen::Vector2d> DivisionModel::undistort(const Eigen::Vector2d& distorted) const
{
  const Eigen::Vector2d d = distorted - center;
  const double denom = 1.0 + lambda * d.squaredNorm();
  if (!(std::abs(denom) > 1e-12))
    return std::nullopt;
  return center + d / denom;
}

std::optional<Eigen::Vector2d> DivisionModel::distort(const Eigen::Vector2d& undistorted) const
{
  const Eigen::Vector2d u = undistorted - center;
  const double ru2 = u.squaredNorm();
  const double disc = 1.0 - 4.0 * lambda * ru2;
  if (!(disc >= 0.0))
    return std::nullopt;
  // r_d = 2 r_u / (1 + sqrt(disc)), so m_d - c = 2 (m_u - c) / (1 + sqrt(disc)): no cancellation near lambda = 0.
  return center + u * (2.0 / (1.0 + std::sqrt(disc)));
}

double lambdaForCornerDisplacement(const Eigen::Vector2d& center, int width, int height, double displacement_px)
{
  // Farthest image corner from the centre: r_d there, and r_u = r_d - displacement.
  double rd = 0.0;
  for (double x : {0.0, width - 1.0})
    for (double y : {0.0, height - 1.0})
      rd = std::max(rd, (Eigen::Vector2d(x, y) - center).norm());
  const double ru = rd - displacement_px;
  return (rd / ru - 1.0) / (rd * rd);
}

Eigen::Isometry3d CameraPose::worldFromCamera() const
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = rotation.transpose();
  t.translation() = center();
  return t;
}

CameraPose CameraPose::fromWorldFromCamera(const Eigen::Isometry3d& world_from_camera)
{
  CameraPose pose;
  pose.rotation = world_from_camera.linear().transpose();
  pose.translation = -pose.rotation * world_from_camera.translation();
  return pose;
}

Matrix34d CameraModel::projectionMatrix() const
{
  Matrix34d rt;
  rt.leftCols<3>() = pose_.rotation;
  rt.col(3) = pose_.translation;
  return intrinsics_.matrix() * rt;
}

std::optional<Eigen::Vector2d> CameraModel::projectUndistorted(const Eigen::Vector3d& world) const
{
  const Eigen::Vector3d xc = toCamera(world);
  if (!(xc.z() > 0.0))
    return std::nullopt;
  const Eigen::Vector3d m = intrinsics_.matrix() * xc;
  return Eigen::Vector2d(m.x() / m.z(), m.y() / m.z());
}

std::optional<Eigen::Vector2d> CameraModel::project(const Eigen::Vector3d& world) const
{
  const auto undistorted = projectUndistorted(world);
  if (!undistorted)
    return std::nullopt;
  return distortion_.distort(*undistorted);
}

std::optional<Eigen::Vector3d> CameraModel::backProject(const Eigen::Vector2d& distorted) const
{
  const auto u = distortion_.undistort(distorted);
  if (!u)
    return std::nullopt;
  const Eigen::Vector3d ray = intrinsics_.matrix().inverse() * Eigen::Vector3d(u->x(), u->y(), 1.0);
  return ray.normalized();
}

}  // namespace insitu_calibration
