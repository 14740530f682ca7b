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
  // Image and world points both noisy (issue 13): each image point to the distorted image of its line's 3D line, the
  // 3D line a free parameter tied to the line's world points by their distances to it (in px: x image_sigma /
  // world_sigma). With exact world points (sigma 0) the 3D line is fixed at the one fitted to them.
  kJoint,
};
std::optional<LineResidual> parseLineResidual(const std::string& name);

struct RefinementOptions
{
  LineResidual line_residual = LineResidual::kImagePoints;
  // kJoint's noise levels: image points' sigma in px (0: estimated from the polylines' scatter about their straight
  // lines, 1 px when no polyline has 3 points) and world points' sigma in m (negative: estimated from lines of 3 or
  // more world points, 0 when there are none; 0: exact). LineCorrespondence::world_point_sigma_m overrides per line.
  double image_sigma_px = 0.0;
  double world_sigma_m = -1.0;
  bool single_focal = false;   // fx = fy
  bool estimate_skew = false;  // skew fixed (at its initial value, normally 0) by default
  bool estimate_distortion = true;
  bool estimate_principal_point = true;  // false: kept at its initial value
  // Weak priors for weakly constrained cameras (0: off): square pixels, (fx - fy) / f ~ N(0, aspect_prior_sigma),
  // and the principal point ~ N(image centre, principal_point_prior_sigma x image width) per axis. Data that determine
  // the camera outweigh them; data that leave a direction open (a partial view of one wall) get a sane answer there,
  // with its uncertainty, instead of an arbitrary one.
  double aspect_prior_sigma = 0.0;
  double principal_point_prior_sigma = 0.0;
  // The principal point prior's mean when it is known (a lab calibration of the camera); none: the image centre.
  std::optional<Eigen::Vector2d> principal_point_prior_center;
  // How the priors are weighed against the residuals: true, by the fit's own noise level (solved again until the two
  // agree), so that they act with their own sigma in the estimate and the covariance alike; false, by the noise
  // level the start's residuals suggest (stiffer by the ratio: the line matcher's search uses it as a regulariser).
  bool priors_at_fit_noise = true;
  RobustLoss loss = RobustLoss::kHuber;
  // The robust loss's scale in px; 0 (the default) sets it to 2.5 times the noise level estimated from the initial
  // camera's residuals (median absolute residual / 0.6745), at least 0.5 px: Huber then treats inliers as Gaussian.
  double loss_scale_px = 0.0;
  int max_iterations = 100;
  // Each world point is paired with its nearest image part; after a solve the pairing is recomputed and the solve
  // repeated while it changes, at most this many times.
  int max_reassignments = 3;
  bool compute_uncertainty = true;
  // Plumb lines (CorrespondenceSet::straight_lines, 3 or more points) join the refinement: each point's distance to
  // its polyline's own straight line after undistortion, which constrains lambda. A polyline farther than
  // max_straight_line_px from straight under the initial camera is left out.
  bool use_straight_lines = true;
  double max_straight_line_px = 0.5;
  // Direction lines (CorrespondenceSet::direction_lines) join the refinement: each point's distance to the line
  // through its direction's vanishing point (and one free angle per line). A line farther than
  // max_direction_line_px from such a line under the initial camera is left out.
  bool use_direction_lines = true;
  double max_direction_line_px = 1.5;
  // A direction line whose points scatter about their fitted line (one free angle) by more than this many times the
  // matched lines' image noise (1.4826 x median distance) is weighed as that noisy (weight noise / its scatter, never
  // raised again) and the solve repeated within the max_reassignments rounds: an unmatched line is any edge the
  // fine-tuning found, e.g. a floor's plank joints at a grazing angle, 1 px off and tilted, where the matched lines
  // sit within 0.1 px; weighed like them, thirty such lines turned a camera 0.4 deg. 0: every line weight 1.
  double direction_line_noise_ratio = 2.0;
  // A direction line's error as a whole, px: its edge a little off the given direction, its fine-tuned image tilted
  // by the texture beside it (plank joints 0.5-1.3 px off their edges, the same sign along the line), the same for all
  // its points, as a matched line's 3D error is. Weighed like it (with weight_by_world_sigma: each point's weight
  // sqrt(s0^2 / (s0^2 + n sigma^2)), n points, s0 = world_sigma_image_noise_px): weighed as exact, thirty such lines
  // outweighed matched lines known to a few tenths of a px and turned a camera 0.9 deg, its principal point 20 px.
  // 0 (default): weight 1. At 0.25 px it cost more than it gained on held-out surveys (precise direction lines weighed
  // down with the rest: docs/measurements.md, "Direction lines weighed as whole lines").
  double direction_line_sigma_px = 0.0;
  // Weight each line by its 3D uncertainty (LineCorrespondence::world_sigma_m; lines without one keep weight 1).
  bool weight_by_world_sigma = true;
  double world_sigma_image_noise_px = 0.1;  // the image noise the 3D uncertainty is weighed against
  // Image-point residuals: after a solve, image points farther from their projected line than
  // max(min_vertex_outlier_px, vertex_outlier_sigmas x the noise level of all image points (1.4826 x median)) are
  // left out and the solve repeated (within the max_reassignments rounds); a line keeps at least two points.
  // Catches a polyline whose end runs past its edge onto the next one. 0: off.
  double vertex_outlier_sigmas = 0.0;
  double min_vertex_outlier_px = 0.15;
  // The residuals of one line are not independent: the error of its 3D line (depth noise, map fusion) and of its
  // fine-tuned image line moves all of them together. The standard deviations are therefore the larger of the
  // usual ones (independent residuals, scaled by their variance) and a jackknife over lines (each line left out in
  // turn, linearised), which holds whatever the correlation within a line.
  bool per_line_uncertainty = true;
  // ... and of a jackknife leaving out two lines at a time (with per_line_uncertainty, up to 32 lines): two wrong
  // correspondences that agree hold the camera between them, each alone moving it little, so that the delete-1
  // jackknife does not see them.
  bool pair_uncertainty = true;
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
  // How much the jackknife over lines widened the standard deviations, at most over the parameters (1: the residuals
  // look independent; much larger: errors shared along lines dominate).
  double line_correlation_factor = 1.0;
  // Condition of the normal equations (column-scaled, smallest / largest eigenvalue): near zero when the data leave
  // a direction of the camera nearly unconstrained (mostly coplanar or parallel lines).
  double reciprocal_condition = 0.0;
};

struct RefinementResult
{
  CameraModel camera;
  bool converged = false;
  std::string termination;  // Ceres' message
  int iterations = 0;
  double initial_rms_px = 0.0;
  double loss_scale_px = 0.0;   // the scale used
  double image_sigma_px = 0.0;  // kJoint: the noise levels used (given or estimated)
  double world_sigma_m = 0.0;
  double final_rms_px = 0.0;
  size_t residuals = 0;
  CameraUncertainty uncertainty;
  // Per input line (NaN for lines not used): the RMS of its residuals at the optimum, and the RMS of its residuals
  // had it been left out of the fit (linearised leave-one-out). A wrong correspondence that pulled the camera onto
  // itself has a small residual but a large leave-one-out residual; infinity when the line alone constrains a
  // direction of the camera (no other line can check it).
  std::vector<double> line_rms_px;
  std::vector<double> line_loo_rms_px;
  // Per input line: Cook's distance, how far the camera would move without the line, in units of its uncertainty
  // (||J dtheta||^2 / (parameters x residual variance)); NaN for lines not used, infinity when it is irreplaceable.
  std::vector<double> line_influence;
};

// Silences Ceres' own log lines (glog on stderr: failed trust-region steps, a rank-deficient covariance), whose
// outcome the results report themselves. Executables call it once at start.
void quietSolverLogging();

// Refines `initial` on the data. `use_line[i]` selects lines (all when empty); points are always used.
Expected<RefinementResult> refineCamera(const CorrespondenceSet& data, const CameraModel& initial,
                                        const RefinementOptions& options = {}, const std::vector<bool>& use_line = {});

// The camera's uncertainty from errors of the lines' 3D positions that the residuals cannot show, such as an error
// every observation of a map line shares (the depth registration's, docs/measurements.md, "Honest sigmas"): line i's
// error is the sum of independent modes error_modes[i][k] x N(0, 1), each a rigid move of its 3D line at one sigma (m;
// e.g. sigma along the rays it was seen on; none: exact), independent of the other lines'; propagated linearly through
// the refinement's least squares at `camera` (refineCamera's optimum on the same data and options; kJoint is
// refused). Sets the standard deviations of fx, fy, cx, cy, lambda, rotation and position.
Expected<CameraUncertainty> propagateWorldLineErrors(const CorrespondenceSet& data, const CameraModel& camera,
                                                     const RefinementOptions& options,
                                                     const std::vector<std::vector<Eigen::Vector3d>>& error_modes);
// The same with sigmas_m[i] in each of the two directions across line i.
std::vector<std::vector<Eigen::Vector3d>> errorsAcrossLines(const CorrespondenceSet& data,
                                                            const std::vector<double>& sigmas_m);

// How the refined camera moves when line i's 3D line moves rigidly by moves_m[i] (linearised at `camera` as above;
// zero: the line stays): the change of fx, of the rotation (the small turn R_new R^T as an angle-axis vector, in
// the refinement's parametrisation) and of the optical centre. With the lines' true offsets as moves (a simulator's
// truth) it says which lines put the camera where it is.
struct CameraShift
{
  double fx_px = 0.0;
  double lambda = 0.0;  // the division model's (1/px^2); 0 when it is not estimated
  Eigen::Vector3d rotation_rad = Eigen::Vector3d::Zero();
  Eigen::Vector3d center_m = Eigen::Vector3d::Zero();
};
Expected<CameraShift> predictCameraShift(const CorrespondenceSet& data, const CameraModel& camera,
                                         const RefinementOptions& options, const std::vector<Eigen::Vector3d>& moves_m);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_REFINE_REFINEMENT_H
