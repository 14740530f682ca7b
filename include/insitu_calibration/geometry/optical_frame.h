// Rotations of a camera's optical frame (REP 103: z forward, x right, y down): in its body frame, and in a world whose
// z is up from the viewing direction.
#ifndef INSITU_CALIBRATION_GEOMETRY_OPTICAL_FRAME_H
#define INSITU_CALIBRATION_GEOMETRY_OPTICAL_FRAME_H

#include <optional>

#include <Eigen/Geometry>

namespace insitu_calibration
{
// REP 103: the optical axes (x right, y down, z forward) in the camera's body frame (x forward, y left, z up), as
// columns: the rotation body_from_optical.
inline Eigen::Matrix3d bodyFromOpticalRotation()
{
  Eigen::Matrix3d r;
  r << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return r;
}

// Looking along a direction: x level (perpendicular to world z), then turned by the roll about the viewing direction.
// Columns right, down, forward. Empty when the direction is zero or (nearly) vertical, where "level" is undefined.
inline std::optional<Eigen::Matrix3d> opticalRotationLookingAlong(const Eigen::Vector3d& direction,
                                                                  double roll_rad = 0.0)
{
  if (!(direction.norm() > 1e-9))
    return std::nullopt;
  const Eigen::Vector3d forward = direction.normalized();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ());
  if (right.norm() < 1e-6)
    return std::nullopt;
  Eigen::Matrix3d rotation;
  rotation.col(0) = right.normalized();
  rotation.col(1) = forward.cross(rotation.col(0));
  rotation.col(2) = forward;
  return rotation * Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitZ());
}

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_GEOMETRY_OPTICAL_FRAME_H
