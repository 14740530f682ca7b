// P = K [R | t] by RQ decomposition of P's left 3x3 block (Hartley & Zisserman, Sec. 6.2.4).
#ifndef INSITU_CALIBRATION_SOLVERS_DECOMPOSITION_H
#define INSITU_CALIBRATION_SOLVERS_DECOMPOSITION_H

#include <vector>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"

namespace insitu_calibration
{
struct DecomposedProjection
{
  Intrinsics intrinsics;  // K(2,2) = 1, fx > 0, fy > 0
  CameraPose pose;        // det(R) = +1
  Matrix34d projection;   // P rescaled so that P = K [R | t] exactly
};

// The overall sign of P is chosen so that det(R) = +1 with positive focal lengths. When scene_points are given,
// they must then lie in front of the camera (most of them, for noisy data); otherwise the result is refused as a
// camera that sees its scene from behind, which only a wrong solution produces.
Expected<DecomposedProjection> decomposeProjection(const Matrix34d& projection,
                                                   const std::vector<Eigen::Vector3d>& scene_points = {});

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_DECOMPOSITION_H
