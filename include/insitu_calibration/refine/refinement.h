// Nonlinear refinement of a camera (intrinsics, division-model distortion, pose) by minimising geometric image
// distances with Ceres, after the linear DLT: for every world point of a line, the distance in pixels of its
// projection through the division model to the image line part nearest to it; for every point correspondence, its
// reprojection error. A robust loss (Huber or Cauchy, scale in px) limits the pull of outliers that RANSAC left.
// The distortion centre is the principal point (the paper's model). Uncertainty comes from the covariance at the
// optimum, scaled by the residual variance.
#ifndef INSITU_CALIBRATION_REFINE_REFINEMENT_H
#define INSITU_CALIBRATION_REFINE_REFINEMENT_H

#include <optional>
#include <string>
#include <vector>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/solvers/correspondences.h"

namespace insitu_calibration
{
enum class RobustLoss
{
  kNone,
  kHuber,
  kCauchy,
};
std::optional<RobustLoss> parseRobustLoss(const std::string& name);
const char* toString(RobustLoss loss);

enum class LineResidual
{
  // Each image point of a line (every vertex of its polyline) to the distorted image of the 3D line through its first
  // and last world points. Uses the curvature the whole polyline shows; lines with one world point fall back to
  // kWorldPoints.
  kImagePoints,
  // Each world point's projection to the image part nearest to it (the paper's pairing, geometric instead of
  // algebraic). Uses only the parts near the world points' projections.
  kWorldPoints,
  // Both of the above: a symmetric transfer error for data where both sides are noisy.
  kBoth,
};

struct RefinementOptions
{
  LineResidual line_residual = LineResidual::kImagePoints;
  bool single_focal = false;   // fx = fy
  bool estimate_skew = false;  // skew fixed (at its initial value, normally 0) by default
  bool estimate_distortion = true;
  RobustLoss loss = RobustLoss::kHuber;
  // The robust loss's scale in px; 0 (the default) sets it to 2.5 times the noise level estimated from the initial
  // camera's residuals (median absolute residual / 0.6745), at least 0.5 px: Huber then treats inliers as Gaussian.
  double loss_scale_px = 0.0;
  int max_iterations = 100;
  // Each world point is paired with its nearest image part; after a solve the pairing is recomputed and the solve
  // repeated while it changes, at most this many times.
  int max_reassignments = 3;
  bool compute_uncertainty = true;
};

// One-sigma uncertainties from the covariance at the optimum.
struct CameraUncertainty
{
  bool available = false;
  std::string reason;  // why not available (e.g. rank deficiency: the data leave the camera under-constrained)
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  double lambda = 0.0;             // 1/px^2
  double position_m = 0.0;         // sqrt of the trace of the centre's covariance: RMS of the 3D position error
  double rotation_deg = 0.0;       // sqrt of the trace of the rotation's covariance: RMS of the rotation angle
  double residual_sigma_px = 0.0;  // noise level estimated from the residuals, which scales the covariance
};

struct RefinementResult
{
  CameraModel camera;
  bool converged = false;
  std::string termination;  // Ceres' message
  int iterations = 0;
  double initial_rms_px = 0.0;
  double loss_scale_px = 0.0;  // the scale used
  double final_rms_px = 0.0;
  size_t residuals = 0;
  CameraUncertainty uncertainty;
};

// Silences Ceres' own log lines (glog on stderr: failed trust-region steps, a rank-deficient covariance), whose
// outcome the results report themselves. Executables call it once at start.
void quietSolverLogging();

// Refines `initial` on the data. `use_line[i]` selects lines (all when empty); points are always used.
Expected<RefinementResult> refineCamera(const CorrespondenceSet& data, const CameraModel& initial,
                                        const RefinementOptions& options = {}, const std::vector<bool>& use_line = {});

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_REFINE_REFINEMENT_H
