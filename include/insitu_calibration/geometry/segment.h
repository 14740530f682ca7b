// A 3D line segment (metres, in the frame of its context: usually the map).
#ifndef INSITU_CALIBRATION_GEOMETRY_SEGMENT_H
#define INSITU_CALIBRATION_GEOMETRY_SEGMENT_H

#include <Eigen/Core>

namespace insitu_calibration
{
struct Segment3d
{
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();

  Eigen::Vector3d pointAt(double t) const { return a + t * (b - a); }
  double length() const { return (b - a).norm(); }
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_GEOMETRY_SEGMENT_H
