// The calibration pipeline from correspondences to a camera, shared by calibrate_lines and the calibration node:
// input checks, the distortion decision, DLT (with the principal-point iteration) and the quality report.
#ifndef INSITU_CALIBRATION_CALIBRATION_H
#define INSITU_CALIBRATION_CALIBRATION_H

#include <optional>
#include <string>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/refine/refinement.h"
#include "insitu_calibration/solvers/ransac.h"
#include "insitu_calibration/solvers/correspondences.h"
#include "insitu_calibration/solvers/dlt.h"

namespace insitu_calibration
{
enum class DistortionMode
{
  kAuto,  // estimate lambda when the data can identify it (curved lines or point correspondences)
  kOn,    // always estimate; an error when the data cannot identify it
  kOff,   // pin-hole only
};
std::optional<DistortionMode> parseDistortionMode(const std::string& name);

// The linear stage that starts RANSAC and the refinement (README, "Method notes").
enum class LinearStage
{
  kParts,      // the paper's DLT-Lines: every world point with every part of its polyline, lambda from the GEP
  kPlumbLine,  // lambda from the straightness of all polylines, each polyline fitted as one line, pin-hole DLT
  kAuto,       // parts; when its lambda is implausible (or it finds no camera) plumb-line, then lambda = 0
};
std::optional<LinearStage> parseLinearStage(const std::string& name);

struct CalibrationOptions
{
  LinearStage linear_stage = LinearStage::kAuto;
  // When the linear lambda is implausible (it would fold the image) or the linear solve fails with it: the pin-hole
  // solve, and the refinement starts from lambda = 0 (instead of refusing).
  bool lambda_fallback = true;
  // The inlier threshold grows with the noise the data show: at least noise_threshold_factor x the median line
  // error of the inliers (so that true lines at 1-3 px noise are kept); 0: the fixed threshold only.
  double noise_threshold_factor = 3.5;
  DltMethod method = DltMethod::kCombined;
  DistortionMode distortion = DistortionMode::kAuto;
  DltOptions dlt;  // method and estimate_distortion are set from the fields above
  // Beyond the paper: RANSAC over lines against wrong correspondences, then nonlinear refinement of geometric errors.
  // Both off reproduce the paper's plain DLT.
  bool ransac = true;
  RansacOptions ransac_options;
  // With a known camera (calibrateCamera's `initial`): when its robust refinement explains at least this fraction
  // of the lines within RANSAC's threshold, RANSAC is not run (it could not find more inliers).
  double anchor_skips_ransac_fraction = 0.9;
  int anchored_ransac_iterations = 300;  // RANSAC's draws at most, with a known camera competing
  // After refinement the inliers are judged again with min(RANSAC's threshold, max(min_inlier_threshold_px,
  // inlier_sigmas x the noise level the residuals show)).
  double inlier_sigmas = 4.0;
  double min_inlier_threshold_px = 0.75;
  // The noise level above from the median absolute residual (true) instead of the residuals' RMS (false): for many
  // automatically matched lines, where the RMS grows with the wrong lines it should find.
  bool robust_noise_level = false;
  // ... and, once refined, by the line's residual had it been left out of the fit (RefinementResult::line_loo_rms_px)
  // against the same threshold.
  bool leave_one_out = false;
  bool refine = true;
  RefinementOptions refinement;
  // When no camera is found: whether the data calibrate with the world mirrored, and then an error that says the
  // frame is left-handed and how to calibrate (instead of the solver's failure). Off by default: a failed solve then
  // costs a second one, which the matcher's many trial calibrations should not pay; calibrate_lines turns it on.
  bool detect_left_handed = false;  // estimate_distortion is set from the distortion decision
};

struct CameraCalibration
{
  CameraModel camera;              // the final camera (refined when refinement ran)
  CameraModel linear_camera;       // the DLT's camera, before refinement
  ReprojectionStats reprojection;  // point-to-line (and point) errors in distorted pixels, over the inliers
  DltResult dlt;
  bool distortion_estimated = false;
  std::string distortion_note;       // why lambda was or was not estimated
  std::string linear_note;           // which linear stage started the refinement, and any fallback
  double inlier_threshold_px = 0.0;  // the threshold the final inliers were judged with
  std::vector<bool> inlier_lines;    // per input line; all true without RANSAC
  size_t inlier_count = 0;
  int ransac_iterations = 0;
  std::optional<RefinementResult> refinement;
  CameraUncertainty uncertainty;  // from the refinement; available = false without it
  int iterations = 0;             // principal-point iterations plus refinement iterations
  bool converged = true;          // the principal-point iteration and the refinement both converged
};

// initial: an approximate camera known beforehand (the matcher's current camera). With RANSAC on it is refined
// robustly on all lines and competes with RANSAC's best hypothesis; the one that explains the lines better (MSAC
// score) chooses the inliers. The linear DLT on those inliers and the refinement follow as without it.
// A final camera that cannot project more than half of its inlier lines' world points (behind it, or outside the
// division model's domain) is kNoSolution: its reprojection statistics would describe only the points left.
Expected<CameraCalibration> calibrateCamera(const CorrespondenceSet& data, const CalibrationOptions& options = {},
                                            const std::optional<CameraModel>& initial = std::nullopt);

// Negates one coordinate (0 x, 1 y, 2 z) of every world point: a left-handed world frame made right-handed.
void mirrorWorld(CorrespondenceSet* data, int axis);
std::optional<int> parseMirrorAxis(const std::string& name);

CalibrationFile toCalibrationFile(const CorrespondenceSet& data, const CameraCalibration& result,
                                  const std::string& world_frame);

// A few lines for people: the camera, its errors, and what was estimated.
std::string describeCalibration(const CameraCalibration& result);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_CALIBRATION_H
