// The moved-camera watchdog's measurement: has a calibrated fixed camera moved since its calibration? Its current
// image lines are matched to the line map projected through the calibration (the matcher's matchLines), and the
// pose change that best re-projects the map onto them is fitted by least squares with the intrinsics and the
// distortion fixed (6 DOF: a rotation about the optical centre and a translation, both in the calibrated camera's
// optical frame). The change is reported as what an operator sees, the image displacement (px) and the rotation
// (deg), each with its one-sigma uncertainty, and judged against thresholds with that uncertainty.
#ifndef INSITU_CALIBRATION_SURVEY_CAMERA_VERIFICATION_H
#define INSITU_CALIBRATION_SURVEY_CAMERA_VERIFICATION_H

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/matching/line_matcher.h"

namespace insitu_calibration
{
struct CameraVerificationOptions
{
  // A camera counts as moved when its displacement or its rotation is above the threshold by more than
  // sigma_factor of its uncertainty, as unmoved when both are below by that much; in between it cannot tell.
  double max_displacement_px = 2.0;
  double max_rotation_deg = 0.2;
  double sigma_factor = 2.0;
  size_t min_matched_lines = 8;  // fewer: "cannot verify"
  // Matching: first a grid of rotations within search_range_deg (search_step_deg apart) is scored by how well the
  // image lines match the map within search_distance_px (a grid step of 0.5 deg is at most about 6 px at a focal
  // length of 1000 px from any rotation in the range); then rounds of matching and fitting from the best rotation,
  // the threshold tightening to distance_factor times the fit's RMS, halving at most per round, never below
  // min_distance_px. A camera moved beyond the range matches too few lines: "cannot verify". Range 0: no search.
  double search_range_deg = 2.0;
  double search_step_deg = 0.5;
  double search_distance_px = 10.0;
  double min_distance_px = 3.0;
  double distance_factor = 4.0;
  double max_angle_deg = 5.0;
  int max_rounds = 6;  // of the full fit, after rotation_only_rounds rounds fitting a rotation only
  int rotation_only_rounds = 2;
  double robust_scale_px = 1.0;  // Huber scale of the fit; residuals above 3 robust sigmas do not enter the result
  // Map lines predicted worse than this (Survey::mapLineSigmas) are left out: the fit weighs every line alike, and
  // lines fused from uncertain depth (5-12 mm) pulled a camera moved by 50 mm to 27.6 mm (camera_watchdog.test with
  // map/max_fusion_sigma 0.012). The map's precise lines are within 3 mm. 0: every line.
  double max_map_line_sigma_m = 0.004;
  LineMatcherOptions matcher;  // the matcher's other options (overlap, length, ambiguity)
};

enum class CameraMotionVerdict
{
  kUnmoved,
  kMoved,
  kUnknown  // too few lines matched, or the motion is too uncertain to tell
};
const char* toString(CameraMotionVerdict verdict);  // "unmoved", "moved", "unknown"

struct CameraMotion
{
  CameraMotionVerdict verdict = CameraMotionVerdict::kUnknown;
  // The pose change in the calibrated camera's optical frame: a point X_c of the calibrated camera is at
  // rotation * X_c + translation in the current one.
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  // angle-axis (rad), translation (m)
  // RMS over the points of the map lines in the calibrated view (visibleMapPoints) of their image shift from the
  // calibrated camera to the current one (undistorted px), and the rotation angle; sigmas are one standard deviation
  // (at least the value an unmoved camera's noise alone would give).
  double displacement_px = 0.0;
  double displacement_sigma_px = 0.0;
  double rotation_deg = 0.0;
  double rotation_sigma_deg = 0.0;
  double translation_m = 0.0;
  double translation_sigma_m = 0.0;
  size_t image_lines = 0;
  size_t matched_lines = 0;
  double rms_px = 0.0;  // of the fit's inliers (line end points to projected map lines)
  std::string message;  // the verdict in words, for diagnostics and the ~verify reply
};

// The pose change of a camera from its calibration to the image lines given (distorted px of its current image),
// fitted to the map lines verificationMapLines keeps (map_line_sigmas_m: optional, parallel to map_lines); the
// displacement is measured at all of them, as an operator sees the overlay.
// Returns a kUnknown result (not an error) when too few lines match. Errors: empty map, invalid image size.
Expected<CameraMotion> verifyCameraPose(const CameraModel& calibrated, int image_width, int image_height,
                                        const std::vector<Segment3d>& map_lines,
                                        const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                        const CameraVerificationOptions& options = {},
                                        const std::vector<double>& map_line_sigmas_m = {});

// The map lines the watchdog fits to: those whose sigma (parallel to map_lines; empty: all) is within
// options.max_map_line_sigma_m.
std::vector<Segment3d> verificationMapLines(const std::vector<Segment3d>& map_lines,
                                            const std::vector<double>& map_line_sigmas_m,
                                            const CameraVerificationOptions& options);

// The image displacement (px, RMS over the points) and rotation (deg) between two poses of a camera with the same
// intrinsics, at the given world points (e.g. two calibrations of one camera, at its map lines' points).
struct PoseDifference
{
  double displacement_px = 0.0;
  double rotation_deg = 0.0;
  double translation_m = 0.0;
};
PoseDifference poseDifference(const CameraModel& before, const CameraPose& after,
                              const std::vector<Eigen::Vector3d>& world_points);

// How far a camera moved from one calibration to the next: poseDifference at the points of the map lines the
// earlier calibration sees (at the image's corners at 5 m when it sees none), and in words ("moved by 3.10 px /
// 0.152 deg / 12.0 mm since the previous calibration").
PoseDifference calibrationChange(const CalibrationFile& before, const CalibrationFile& after,
                                 const std::vector<Segment3d>& map_lines);
std::string describeChange(const PoseDifference& change);

// Points along the parts of the map lines a camera sees (samples_per_line each), for poseDifference.
std::vector<Eigen::Vector3d> visibleMapPoints(const CameraModel& camera, int image_width, int image_height,
                                              const std::vector<Segment3d>& map_lines, int samples_per_line = 5);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_CAMERA_VERIFICATION_H
