// The DLT front end: DLT-Points, DLT-Lines or both stacked, without or with the division model, Hartley-normalised,
// with the paper's principal-point iteration (Fig. 3: solve, re-centre the distortion on the estimated principal
// point, solve again until it stops moving) and the decomposition P -> K, R, t.
#ifndef INSITU_CALIBRATION_SOLVERS_DLT_H
#define INSITU_CALIBRATION_SOLVERS_DLT_H

#include <optional>
#include <string>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/solvers/correspondences.h"

namespace insitu_calibration
{
enum class DltMethod
{
  kLines,     // line correspondences only
  kPoints,    // point correspondences only
  kCombined,  // both, stacked in one system
};

std::optional<DltMethod> parseDltMethod(const std::string& name);
const char* toString(DltMethod method);

struct DltOptions
{
  DltMethod method = DltMethod::kCombined;
  bool estimate_distortion = false;
  bool normalize = true;  // Hartley normalisation; off only to measure what it brings
  // Fixed distortion centre; when unset the image centre is used first and then the principal-point iteration.
  std::optional<Eigen::Vector2d> distortion_center;
  bool recenter_distortion = true;
  int max_center_iterations = 50;
  double center_tolerance_px = 1e-6;
  bool polish_lambda = true;
};

struct DltResult
{
  CameraModel camera;                        // K, division model (lambda, centre) and pose
  Matrix34d projection = Matrix34d::Zero();  // K [R | t], world metres to undistorted pixels
  double algebraic_residual = 0.0;
  double null_space_gap = 0.0;
  size_t constraints = 0;  // point-line pairs plus two per point correspondence
  size_t lines_used = 0;
  size_t points_used = 0;
  bool distortion_estimated = false;
  int center_iterations = 0;     // solves performed by the principal-point iteration
  bool center_converged = true;  // false when the iteration ran out before the centre stopped moving
  double center_last_step_px = 0.0;
};

// The linear solve for one distortion centre, without decomposition: what RANSAC and the iteration call.
struct DltLinearSolution
{
  Matrix34d projection;  // world -> undistorted pixels, ||P|| arbitrary, sign arbitrary
  double lambda = 0.0;   // 1/px^2, around `center`
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double algebraic_residual = 0.0;
  double null_space_gap = 0.0;
  size_t constraints = 0;
};
Expected<DltLinearSolution> solveDltLinear(const CorrespondenceSet& data, const DltOptions& options,
                                           const Eigen::Vector2d& center);

// Checks the data against the model's needs: counts, finite values, the method's inputs present, and the
// degenerate configurations (coplanar 3D data, all lines parallel, all lines through one point).
Status checkDltInput(const CorrespondenceSet& data, const DltOptions& options);

Expected<DltResult> solveDlt(const CorrespondenceSet& data, const DltOptions& options = {});

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_DLT_H
