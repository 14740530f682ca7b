// The noise the refinement's error model needs (issue 13): how far the image points scatter about their lines and
// how far the world points scatter about theirs, estimated from the data when not given, and the 3D line fitted to
// a line's world points.
#ifndef INSITU_CALIBRATION_REFINE_NOISE_MODEL_H
#define INSITU_CALIBRATION_REFINE_NOISE_MODEL_H

#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/solvers/correspondences.h"

namespace insitu_calibration
{
struct NoiseLevels
{
  double image_sigma_px = 1.0;
  double world_sigma_m = 0.0;
  bool image_estimated = false;  // from polylines of 3+ points (else the given value or the 1 px default)
  bool world_estimated = false;  // from lines of 3+ world points (else the given value or 0: exact)
};

// given_image_px > 0 and given_world_m >= 0 are used as they are; otherwise estimated: the image noise from the
// scatter of every polyline of 3 or more points about its straight line after undistortion with `camera`, the world
// noise from the scatter of every line's 3 or more world points about their fitted 3D line (pooled, with their
// degrees of freedom).
NoiseLevels estimateNoiseLevels(const CorrespondenceSet& data, const DivisionModel& distortion, double given_image_px,
                                double given_world_m);

// The 3D line through world points (least squares; the line through them for two): the first and last point
// projected onto it.
struct FittedLine3d
{
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
};
FittedLine3d fitWorldLine(const std::vector<Eigen::Vector3d>& points);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_REFINE_NOISE_MODEL_H
