// One fixed camera of the building as the calibration node handles it, without ROS: its configuration (a prior or
// a manual correspondence file), the temporal median of its recent images, the lines of that median, their matches
// to the 3D line map, and its calibration with the sanity checks a published calibration must pass.
#ifndef INSITU_CALIBRATION_SURVEY_FIXED_CAMERA_H
#define INSITU_CALIBRATION_SURVEY_FIXED_CAMERA_H

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "insitu_calibration/calibration.h"
#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/lines/image_lines.h"
#include "insitu_calibration/map/joint_lines.h"
#include "insitu_calibration/map/surface_voxels.h"
#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/survey/camera_verification.h"
#include "insitu_calibration/survey/image_explanation.h"
#include "insitu_calibration/survey/temporal_median.h"
#include "insitu_calibration/survey/view_ambiguity.h"

namespace insitu_calibration
{
struct FixedCameraConfig
{
  std::string name;
  std::string image_topic;
  int image_width = 0;
  int image_height = 0;
  std::optional<CameraPrior> prior;  // automatic matching against the line map
  std::string correspondence_file;   // or the paper's hand-picked workflow: calibrate_lines' input format

  // Errors: empty name, non-positive size, neither a prior nor a correspondence file.
  Status validate() const;
};

// How a refusal for a camera whose sigmas exceed the limits (max_sigma_*) begins (kDegenerate).
constexpr const char* kWeaklyDeterminedRefusal = "the matched lines determine the camera too weakly";
// How a refusal for a camera without images begins (kNotEnoughData).
constexpr const char* kNoImageRefusal = "no image has arrived from ";

struct FixedCameraOptions
{
  size_t median_images = 15;
  ImageLineOptions image_lines;
  // How far a thin image line's 3D line (a joint's centre: RefinerOptions::thin_lines) may be from the map line it
  // matches, m: the map holds a joint's edges, each half its width from the centre (joints of tiles, bricks and
  // planks are 2-12 mm wide). Its match counts as a map line this much less certain (matchAndCalibrate). Thin lines
  // are extracted (image_lines.refiner.thin_lines, off by default) only once a camera is known: from the prior their
  // repetition would offer the search a match one joint over.
  double thin_line_sigma_m = 0.003;
  // Map lines that are one flank of a joint this camera does not resolve (map/joint_lines.h, judged from the
  // prior's position and field of view) count as less certain by half the joint's width.
  UnresolvedJointOptions unresolved_joints;
  LineMatcherOptions matcher;
  int max_loops = 3;                // the paper's loop: extract lines with the current distortion, calibrate, repeat
  double loop_tolerance_px = 0.05;  // ... until the principal point and the corner distortion move less than this
  // Sanity checks of a result before it is published.
  double min_focal_ratio = 0.2;  // focal length / image width
  double max_focal_ratio = 10.0;
  double max_rms_px = 1.5;
  size_t min_matched_lines = 8;
  double max_prior_distance_sigmas = 6.0;  // the camera must be within this many position sigmas of its prior
  // A result whose own one-sigma uncertainty exceeds any of these is refused as under-constrained (mostly coplanar
  // or parallel lines, a small part of the view): better an error than a confident wrong camera. A rank-deficient
  // result (no uncertainty) is refused too. A third of the errors that make a result wrong (5 % focal length, 10 cm,
  // 2 deg) or less: at 0.03 / 0.15 / 1.5 generated buildings gave accepted cameras 1.4 deg and 13 cm off with
  // sigmas of 1 deg and 8 cm; the default world's correct results have at most 0.2 %, 11 mm and 0.13 deg.
  double max_sigma_focal_relative = 0.01;
  double max_sigma_position_m = 0.03;
  double max_sigma_rotation_deg = 0.5;
  // The final check (image_explanation.h): the camera must explain the image as a whole (its projected map lines on
  // image edges, its matched lines predicted when held out).
  ImageExplanationOptions explanation;
  // ... and no camera at a clearly different pose may explain it about as well (view_ambiguity.h: a view of a
  // repeating structure, floor tiles or a row of identical windows, does not decide the camera).
  ViewAmbiguityOptions ambiguity;
};

struct FixedCameraStatus
{
  bool has_image = false;
  size_t images = 0;
  size_t image_lines = 0;
  size_t map_lines = 0;
  size_t map_lines_visible = 0;
  size_t matched_lines = 0;
  double coverage_percent = 0.0;
  bool calibrated = false;
  bool ready = false;
  std::string message;
};

struct FixedCameraResult
{
  CameraCalibration calibration;
  CalibrationFile file;
  std::vector<std::vector<Eigen::Vector2d>> matched_image_lines;
  std::vector<Segment3d> matched_map_lines;
  // The image lines the final calibration did not use (not matched, or outliers of a correspondence file).
  std::vector<std::vector<Eigen::Vector2d>> unmatched_image_lines;
  CorrespondenceSet correspondences;  // the lines calibrated on (calibration.inlier_lines indexes them)
  int loops = 0;
  ImageExplanation explanation;  // the final check's measurements (map-based calibrations)
  ViewAmbiguity ambiguity;       // its ambiguity test (map-based calibrations that passed the other checks)
  std::string summary;           // how good the result is, in words
  // The map lines (their parts not hidden from the camera) the final check assessed, sampled as it saw them: the
  // report's overlay draws them.
  std::vector<EdgeSamples> checked_map_lines;
};

// Whether a result's own one-sigma uncertainty (the matched lines') is within the limits (max_sigma_*); else the
// refusal (kDegenerate, beginning with kWeaklyDeterminedRefusal) with what would determine the camera: when its
// rotation alone fails and mostly through its principal point, a principal point in the prior (unless it has one).
Status checkDetermined(const CameraUncertainty& uncertainty, const Intrinsics& intrinsics, const CameraPrior* prior,
                       const FixedCameraOptions& options);

class FixedCamera
{
public:
  FixedCamera(const FixedCameraConfig& config, const FixedCameraOptions& options);

  const FixedCameraConfig& config() const { return config_; }
  // Adds an image to the median buffer. Errors: empty, or a size other than the configured one.
  Status addImage(const cv::Mat& image);
  cv::Mat medianImage() const { return median_.median(); }
  size_t imageCount() const { return median_.size(); }  // in the median buffer (cheap, unlike medianImage)

  // Calibrates from the line map (prior) or the correspondence file, and keeps the result when it passes the
  // sanity checks. Errors say what is missing or wrong.
  // map_line_sigmas_m: optional, per map line how far off it may be (Survey::mapLineSigmas).
  Expected<FixedCameraResult> calibrate(const std::vector<Segment3d>& map_lines, const std::string& world_frame,
                                        const std::vector<double>& map_line_sigmas_m = {});
  FixedCameraStatus status(const std::vector<Segment3d>& map_lines) const;
  // The moved-camera check (camera_verification.h): the lines of the median of the recent images, extracted with the
  // calibration's distortion, against the map lines projected through the calibration. Errors: not calibrated, no
  // image, the extraction failed, an empty map. map_line_sigmas_m: optional, parallel to map_lines
  // (verifyCameraPose).
  Expected<CameraMotion> verify(const std::vector<Segment3d>& map_lines, const CameraVerificationOptions& options = {},
                                const std::vector<double>& map_line_sigmas_m = {}) const;

  const std::optional<CalibrationFile>& calibration() const { return calibration_; }
  const std::optional<FixedCameraResult>& lastResult() const { return last_result_; }
  // The last result the checks refused (for diagnostics against a simulator's truth), if the last calibration got
  // that far.
  const std::optional<FixedCameraResult>& lastRefused() const { return last_refused_; }
  // Whether a camera's focal lengths are within the plausible range (FixedCameraOptions::min_focal_ratio and
  // max_focal_ratio times the image width): a result outside it is not a camera to project anything through.
  bool focalIsPlausible(const CameraModel& camera) const;
  // And its position within the prior's distance limit (FixedCameraOptions::max_prior_distance_sigmas; any without
  // a prior): a result the check refuses for either is no view of the building to guide a survey by.
  bool isPlausible(const CameraModel& camera) const;
  // The line matcher's options for this camera: the survey's, with the principal point the prior knows (if any) as
  // the refinement's principal point prior.
  LineMatcherOptions matcherOptions() const;
  void setCalibration(const CalibrationFile& calibration) { calibration_ = calibration; }
  const FixedCameraOptions& options() const { return options_; }
  // Survey::setCameraOptions (median_images as at construction).
  void setOptions(const FixedCameraOptions& options);
  // Forgets images, matches and calibration.
  void reset();
  // The surfaces the survey measured: the final check leaves out the map lines (or their parts) they hide from the
  // camera. None: every map line in view counts.
  void setOccluders(std::shared_ptr<const SurfaceVoxels> occluders) { occluders_ = std::move(occluders); }

  // The camera used to look at the map: the calibration when there is one, else the prior's.
  std::optional<CameraModel> currentCamera() const;
  // The final check's measurement (image_explanation.h) of any camera against the median image: the map lines in its
  // view less those the occluders (none: nothing hidden) hide from it. For a result, and for the truth's camera in
  // diagnostics (with Survey::surfaces()). options: the check's (none: the camera's own).
  ImageExplanation explain(const CameraModel& camera, const std::vector<Segment3d>& map_lines,
                           const SurfaceVoxels* occluders, const RefinementResult* refinement = nullptr,
                           std::vector<EdgeSamples>* checked_lines = nullptr,
                           const ImageExplanationOptions* options = nullptr) const;

private:
  Expected<FixedCameraResult> calibrateFromFile(const std::string& world_frame);
  Expected<FixedCameraResult> calibrateFromMap(const std::vector<Segment3d>& map_lines, const std::string& world_frame,
                                               const std::vector<double>& map_line_sigmas_m);
  // One loop's matching: the prior search when no camera is found yet, else the matching again from the camera found
  // (with the principal point the prior knows, if any).
  Expected<LineMatchResult> matchOnce(const std::vector<Segment3d>& map_lines,
                                      const std::vector<std::vector<Eigen::Vector2d>>& polylines,
                                      const std::vector<double>& map_line_sigmas_m,
                                      const std::vector<double>& image_line_sigmas,
                                      const std::vector<double>& final_sigmas, const CameraModel* found) const;
  // A matching's result as the camera's: its matched and unmatched image lines, correspondences and calibration file.
  FixedCameraResult resultOfMatching(LineMatchResult matched,
                                     const std::vector<std::vector<Eigen::Vector2d>>& polylines,
                                     const std::vector<Segment3d>& map_lines, const std::string& world_frame) const;
  // The sigmas of a result's final calibration: the flanks of joints this camera does not resolve, as seen from the
  // prior, grown (map/joint_lines.h); the map lines' own without a prior.
  std::vector<double> finalSigmas(const std::vector<Segment3d>& map_lines, const std::vector<double>& sigmas) const;
  // The map lines not hidden from every viewpoint near the prior by the occluders (all without either), with their
  // sigmas (when given) kept in step.
  std::vector<Segment3d> seeableFromPrior(const std::vector<Segment3d>& map_lines, std::vector<double>* sigmas) const;
  // check_prior: also the distance to the prior (the ambiguity test weighs that itself).
  Status check(const CameraCalibration& calibration, size_t matched_lines, bool check_prior = true) const;
  // The final check of a map-based result: measures how well it explains the median image, refuses it if badly.
  Status checkExplanation(FixedCameraResult& result, const std::vector<Segment3d>& map_lines) const;
  // The map lines in the camera's view, clipped to it, less the parts the occluders (none: nothing) hide from it.
  std::vector<Segment3d> unhiddenLines(const CameraModel& camera, const std::vector<Segment3d>& map_lines,
                                       const SurfaceVoxels* occluders) const;
  // Its ambiguity test: refuses a result when a camera at a clearly different pose explains the image about as well
  // and would pass the checks too.
  // Whether the prior makes an alternative camera implausible (ViewAmbiguityOptions::prior_margin_sigmas).
  bool priorRulesOut(const CameraModel& alternative, const CameraModel& accepted) const;
  Status checkAmbiguity(FixedCameraResult& result, const std::vector<Segment3d>& map_lines,
                        const std::vector<double>& map_line_sigmas_m) const;
  // The test's verdict on the alternatives it found (each one's `dismissed`, or the refusal).
  Status judgeAlternatives(FixedCameraResult& result, const std::vector<Segment3d>& map_lines) const;
  // Replaces a result that passed the checks by the test's start at the same camera that explains the image better
  // (ViewAmbiguityOptions::better_score_margin) when that one passes them all too.
  void takeBetterExplanation(FixedCameraResult& result, const std::vector<Segment3d>& map_lines,
                             const std::string& world_frame) const;
  // The median image's lines under a distortion for the calibration loop: thin lines (thin_lines) only once a camera
  // is known (camera_known), or from the start in a view with no edge line at all; thin_lines says whether they were
  // fine-tuned. No line: an error that says what the view shows.
  Expected<std::vector<ImageLine>> linesOfMedian(const cv::Mat& median, const DivisionModel& distortion,
                                                 bool camera_known, bool* thin_lines) const;
  // The image lines of the median image under a distortion (the polylines only).
  Expected<std::vector<std::vector<Eigen::Vector2d>>> medianLines(const DivisionModel& distortion) const;
  void measureVerificationReference(const std::vector<Segment3d>& map_lines,
                                    const std::vector<double>& map_line_sigmas_m);

  FixedCameraConfig config_;
  FixedCameraOptions options_;
  TemporalMedian median_;
  std::optional<CalibrationFile> calibration_;
  std::optional<FixedCameraResult> last_result_;
  std::optional<FixedCameraResult> last_refused_;
  size_t last_matched_ = 0;
  std::shared_ptr<const SurfaceVoxels> occluders_;
  // The watchdog's zero (verify): the pose its own fit finds on the images of the calibration, kept with the
  // calibrated pose it belongs to. Its line-end fit and the calibration's adjustment weigh the lines differently:
  // their optima lie a few millimetres apart, which would otherwise read as a motion. None after a restart (the
  // images are gone): the calibration itself is the zero then.
  struct VerificationReference
  {
    CameraPose calibrated;
    CameraPose reference;
  };
  std::optional<VerificationReference> verification_reference_;
};

// The coverage grid: kCoverageCells x kCoverageCells cells of the image, row-major, true where the lines' points
// touch the cell.
constexpr int kCoverageCells = 4;
std::vector<bool> imageCoverageCells(const std::vector<std::vector<Eigen::Vector2d>>& lines, int width, int height);
// Share of the image (the coverage grid's cells) that the lines' points touch, in percent.
double imageCoverage(const std::vector<std::vector<Eigen::Vector2d>>& lines, int width, int height);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_FIXED_CAMERA_H
