// A survey in progress, without ROS: RGB-D keyframes become 3D lines in the line map, fixed-camera images feed
// each camera's temporal median, and each camera calibrates against the map on request. The calibration node and
// the offline tool calibrate_survey both drive one.
#ifndef INSITU_CALIBRATION_SURVEY_SURVEY_H
#define INSITU_CALIBRATION_SURVEY_SURVEY_H

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <cstdint>
#include <string>
#include <vector>

#include "insitu_calibration/lines/line_map.h"
#include "insitu_calibration/lines/rgbd_lines.h"
#include "insitu_calibration/map/ceiling_lines.h"
#include "insitu_calibration/map/floor_lines.h"
#include "insitu_calibration/map/triangulated_lines.h"
#include "insitu_calibration/map/line_map_adjustment.h"
#include "insitu_calibration/map/surface_voxels.h"
#include "insitu_calibration/survey/fixed_camera.h"
#include "insitu_calibration/survey/keyframe_selector.h"
#include "insitu_calibration/survey/map_placement.h"

namespace insitu_calibration
{
struct SurveyOptions
{
  KeyframeOptions keyframes;
  RgbdLineOptions rgbd;
  LineMapOptions map;
  FixedCameraOptions cameras;
  int min_map_support = 2;               // map lines seen fewer times are not used for calibration
  double max_map_spread_m = 0.01;        // nor map lines whose observations disagree more (MapLine::spread)
  double min_map_line_sigma_m = 0.0005;  // added (in quadrature) to a map line's predicted error (mapLineSigmas)
  // Also add the error the line's observations share (Line3d::sigma_systematic_m, the depth registration's
  // uncertainty at the edge) to mapLineSigmas. Off: on the simulator's realistic buildings it makes the map lines'
  // sigmas cover their offsets (median offset / sigma 1.3-5.9 -> 0.9-1.6), but the calibration's refinement then
  // weighs the lines so unevenly that one held-out camera came out 1.5 deg off with a 0.33 deg sigma (README).
  bool shared_map_line_sigma = false;
  // The calibration's reported uncertainty includes the map lines' shared errors (min_map_line_sigma_m and the
  // registration's, as mapLineSigmas adds them with shared_map_line_sigma), propagated through its least squares
  // (propagateWorldLineErrors): errors common to every observation of an edge move the map line as a whole, and a
  // camera fitted to such lines takes up what their residuals cannot show. Only the reported sigmas change, after the
  // checks (like the map's placement): not the estimate, nor which cameras are accepted.
  bool shared_map_errors_in_sigma = true;
  double fixed_image_period_s = 0.5;  // one image per period per camera goes into its median
  // The localiser behind the keyframes' poses (tf): its error's standard deviation in x, y and yaw, and its
  // correlation time. With a sigma above 0 the map is adjusted jointly with the keyframe poses
  // (line_map_adjustment.h) before it is used, and a calibration's uncertainty includes the map's placement (the
  // localiser's error averaged over the survey: about sigma * sqrt(2 correlation / survey time), at most sigma;
  // map_placement.h).
  // 0: tf is trusted as exact (the map as inserted, no placement uncertainty).
  double localization_sigma_m = 0.02;
  double localization_sigma_deg = 0.5;
  double localization_correlation_s = 5.0;
  int adjustment_rounds = 4;  // graduated: merge tolerances widened by the localiser's error, narrowing to the map's
  LineMapAdjustmentOptions adjustment;  // its localization sigmas and correlation are set from the three above
  // Lines on the floor beyond the depth range (map/floor_lines.h), added to the map in use (adjusted or not).
  FloorLineOptions floor;
  // Lines on the ceiling (a horizontal plane above the Xtion that depth measured) whose own depth is too poor for
  // the map, or missing (map/ceiling_lines.h), added after the floor lines.
  CeilingLineOptions ceiling;
  // Lines beyond the depth range triangulated from RGB segments of five or more keyframes
  // (map/triangulated_lines.h), added to the map in use after the floor lines.
  TriangulatedLineOptions triangulated;
  // The surfaces the keyframes' depth measured (map/surface_voxels.h): the final check leaves out map lines they
  // hide from a fixed camera.
  SurfaceVoxelOptions occlusion;
  // A camera the map in use cannot calibrate (refused: too few matches, too weakly determined, not explaining its
  // image) is tried once more against the map with its extensions, which add lines where depth alone is too
  // uncertain (far walls) or out of reach (the ceiling) but each let a wrong camera through somewhere when used for
  // every camera (docs/measurements.md): a camera the map in use calibrates keeps that result. On since 2026-12-08:
  // on the held-out sets AK and AL it gained 7 good, 1 fair and 2 off of 31 refused cameras, none wrong.
  struct ExtendedMapRetry
  {
    bool enabled = true;
    double max_fusion_sigma_m = 0.012;  // LineMapOptions::max_fusion_sigma_m of the extended map (0: no fusion)
    bool ceiling_lines = true;          // CeilingLineOptions::enabled of the extended map
  } extended_retry;
};

// The options of the map with its extensions (SurveyOptions::extended_retry): fusion and ceiling lines on, each at
// least as the retry asks.
SurveyOptions extendedMapOptions(const SurveyOptions& options);

// Whether the retry on the extended map can differ from the map in use: enabled, and adding fusion or ceiling lines
// the options do not have already.
bool extendedRetryAdds(const SurveyOptions& options);

// What a camera is calibrated against: the map lines the calibration uses, as segments, with their sigmas.
struct CalibrationMap
{
  std::vector<MapLine> lines;
  std::vector<Segment3d> segments;
  std::vector<double> sigmas;
  bool extended = false;  // the map with its extensions (SurveyOptions::extended_retry)
};

// Whether a refusal is one the extended map may turn: too few matches, too weakly determined, or no acceptable
// solution (not kInvalidInput, nor a camera without images, nor the ambiguity test's refusal: isAmbiguityRefusal).
bool extendedRetryWorthwhile(const Error& refusal);

// Calibrates the camera against map; a refusal that extendedRetryWorthwhile (of a camera without a correspondence
// file, which does not use the map) is tried once more against extended()
// (called only then; a map without lines: no retry). An accepted retry says so in its summary and quality extras
// (extended_map 1); a refused one keeps the first refusal (its advice is for the map in use) with the second's reason
// noted. *used (optional): the map the result came from.
Expected<FixedCameraResult> calibrateWithExtendedRetry(FixedCamera& camera, const std::string& world_frame,
                                                       const CalibrationMap& map,
                                                       const std::function<CalibrationMap()>& extended,
                                                       CalibrationMap* used = nullptr);

struct SurveyStats
{
  size_t frames = 0;            // RGB-D frames offered
  size_t keyframes = 0;         // used
  size_t skipped = 0;           // refused (invalid frame or extraction error)
  size_t lines = 0;             // 3D lines extracted in keyframes
  size_t floor_candidates = 0;  // RGB lines without depth kept as floor candidates (floor lines enabled)
  size_t floor_refused = 0;     // ... refused because their depth disagrees with the floor
  // The last map adjustment (0 when none ran).
  size_t adjusted_observations = 0;
  size_t dropped_observations = 0;
  double adjustment_cpu_ms = 0.0;
  double mean_correction_m = 0.0;  // RMS of the keyframes' x, y corrections
  double mean_correction_deg = 0.0;
};

// One map adjustment's outcome (Survey::computeAdjustment), for the keyframes it was computed from.
struct MapAdjustment
{
  LineMap map;
  std::vector<PoseCorrection> corrections;
  size_t observations = 0;
  size_t dropped = 0;
  double cpu_ms = 0.0;
  uint64_t generation = 0;  // Survey::keyframeGeneration() of its keyframes
  // The keyframes' depth under the corrected poses (when the survey tests occlusion): at tf's poses a localiser's
  // error smears the surfaces, and a smeared wall hides the lines on it from a camera that sees it at a grazing angle.
  std::shared_ptr<SurfaceVoxels> surfaces;
};

// A camera refused as weakly determined (kWeaklyDeterminedRefusal) while the survey assumes a localiser error
// (options.localization_sigma_*): the refusal, with a note that the map was adjusted for that error and how to take
// exact poses as they are. Other refusals unchanged.
Error withAssumedLocaliser(const Error& refusal, const SurveyOptions& options);

class Survey
{
public:
  Survey(const std::vector<FixedCameraConfig>& cameras, const SurveyOptions& options = {});

  // A frame of the robot's RGB-D camera with its pose. Returns whether it was used as a keyframe; errors describe
  // a frame that could not be used (invalid, or the extraction failed).
  // T_odom_camera: the camera in the odometry frame at the frame's stamp, when there is odometry (ties consecutive
  // keyframes in the map adjustment).
  // keyframe_segments (optional): when the frame became a keyframe, its RGB segments as the map's extraction found
  // them (fine-tuned, distorted px), for the depth registration estimate without detecting them again.
  Expected<bool> addRgbdFrame(const RgbdFrame& frame,
                              const std::optional<Eigen::Isometry3d>& T_odom_camera = std::nullopt,
                              std::vector<Segment2d>* keyframe_segments = nullptr);
  // An image of a fixed camera (stamp in seconds). Returns whether it joined the median. Errors: unknown camera,
  // empty image, wrong size.
  Expected<bool> addFixedImage(const std::string& camera, const cv::Mat& image, double stamp);

  // The map lines with enough support, as segments.
  std::vector<Segment3d> mapSegments() const;
  // The map lines behind mapSegments() (same order): support and spread within the options' limits.
  std::vector<MapLine> usedMapLines() const;
  // Per map segment (same order) how far off it may be, m: its predicted standard error (MapLine::sigma) and
  // min_map_line_sigma_m in quadrature (its spread, at least min_map_line_sigma_m, when nothing is predicted).
  std::vector<double> mapLineSigmas() const;
  // The map in use: adjusted with the keyframe poses when the localiser has an error (computed on first use after
  // new keyframes), else the map as inserted.
  const LineMap& lineMap() const;
  const SurveyStats& stats() const { return stats_; }
  const std::vector<Keyframe>& keyframes() const { return keyframe_data_; }
  // The surfaces the keyframes' depth measured (none when options().occlusion is off); later keyframes go into a
  // copy, so the pointer stays valid and unchanged for whoever holds it.
  std::shared_ptr<const SurfaceVoxels> surfaces() const { return surfaces_; }
  // Per keyframe the adjustment's correction of the pose tf gave (zeros without an adjustment).
  std::vector<PoseCorrection> poseCorrections() const;
  // The whole survey's placement (the localiser's error averaged over every keyframe; zero sigmas without an
  // adjustment), and that of the keyframes that observed the given lines (map_placement.h).
  MapPlacementUncertainty mapPlacement() const;
  MapPlacementUncertainty mapPlacementOf(const std::vector<const MapLine*>& lines) const;

  // Calibrates one camera against the map in use (FixedCamera::calibrate with the map's segments and sigmas; a
  // refusal tried again on the extended map when options().extended_retry is on: calibrateWithExtendedRetry) and
  // adds the map's placement uncertainty to the result's pose sigmas. Errors as FixedCamera::calibrate.
  Expected<FixedCameraResult> calibrate(const std::string& name, const std::string& world_frame);
  // Sets a camera's final-check ceiling (ImageExplanationOptions::ceiling_height_m) to the plane the keyframes' depth
  // lines measured (measureCeilingHeight), none where they measured none: calibrate() does it, and the node for the
  // copy it calibrates.
  void useSurveyCeiling(FixedCamera& camera) const;
  // The map lines a calibration uses of a map (usedMapLines' selection), with their segments and sigmas.
  CalibrationMap calibrationMapOf(const LineMap& map, bool extended = false) const;
  // The extended map (extendedMapOptions) of the keyframes at the corrected poses (corrections: one per keyframe or
  // fewer, the rest taken as tf gave them), for a caller that must not hold the survey while it is built (the node);
  // pass it to calibrationMapOf with extended true.
  static LineMap computeExtendedMap(const std::vector<Keyframe>& keyframes, std::vector<PoseCorrection> corrections,
                                    const SurveyOptions& options);
  // The corrections of the last installed adjustment (latestLineMap's), none without one.
  const std::vector<PoseCorrection>& latestPoseCorrections() const { return corrections_; }
  // The map's placement uncertainty added to a calibration made against used_lines (usedMapLines(), or the lines of
  // the CalibrationMap it was made against: the node calibrates a copy of a camera outside its lock, and the map may
  // be adjusted meanwhile) to its sigmas and its file's quality, with the used lines' shared errors
  // (SurveyOptions::shared_map_errors_in_sigma). False when there is none to add.
  bool addMapPlacement(FixedCameraResult* result, const std::vector<MapLine>& used_lines) const;
  // The map lines (of used_lines) a result's final refinement used: its inlier correspondences' source lines, in their
  // order (nullptr for one whose line is not among used_lines).
  static std::vector<const MapLine*> matchedMapLines(const FixedCameraResult& result,
                                                     const std::vector<MapLine>& used_lines);

  bool hasCamera(const std::string& name) const { return cameras_.count(name) > 0; }
  std::vector<std::string> cameraNames() const;
  FixedCamera& camera(const std::string& name) { return *cameras_.at(name); }
  const FixedCamera& camera(const std::string& name) const { return *cameras_.at(name); }

  // The frames that follow come from another recording of the same building (calibrate_survey with several bags):
  // the next keyframe is not tied to the last one by odometry or the localiser's chain (Keyframe::starts_recording),
  // and is kept wherever it is. The map, the keyframes and the cameras' images so far stay.
  void startRecording();
  // Forgets one camera's images and calibration.
  void resetCamera(const std::string& name) { cameras_.at(name)->reset(); }
  // Forgets everything: the map, the keyframes and every camera.
  void reset();

  const SurveyOptions& options() const { return options_; }
  // New options for every fixed camera (thresholds tuned while the node runs), from their next calibration or
  // status on; median_images keeps its start-up value (the median buffers are sized by it), and the final check's
  // floor is the survey's (FloorLineOptions: floor_height_m, min_edge_height_m / 2).
  void setCameraOptions(const FixedCameraOptions& options);

  // The map adjustment apart from the survey, for a caller that must not hold the survey while it runs (the node
  // holds its lock for every survey call; an adjustment takes seconds): under the lock, adjustmentDue() and a copy
  // of keyframes() and keyframeGeneration(); without it, computeAdjustment(); under it again, installAdjustment(),
  // which keeps the result (the latest*() accessors show it) and counts it as current if no keyframe came meanwhile.
  bool adjustmentDue() const { return adjusting() && !adjusted_; }
  uint64_t keyframeGeneration() const { return keyframe_generation_; }
  static MapAdjustment computeAdjustment(const std::vector<Keyframe>& keyframes, const SurveyOptions& options,
                                         uint64_t generation);
  // False (nothing kept) for an adjustment computed before the last reset().
  bool installAdjustment(MapAdjustment adjustment);
  // The map as the last adjustment left it, never adjusting (status and display while the survey runs): the last
  // installed adjustment, even if keyframes came since, else the map as inserted. Same meaning as the functions
  // above otherwise.
  const LineMap& latestLineMap() const;
  std::vector<Segment3d> latestMapSegments() const;
  std::vector<double> latestMapLineSigmas() const;

private:
  bool adjusting() const;
  // The placement of the mean over the keyframes selected (zero sigmas without an adjustment).
  MapPlacementUncertainty placementOver(const std::vector<size_t>& selected) const;
  void adjustMap() const;
  void cacheAdjustment(MapAdjustment adjustment) const;  // the cache's members are mutable
  std::vector<MapLine> usedLinesOf(const LineMap& map) const;
  std::vector<double> sigmasOf(const std::vector<MapLine>& used) const;
  bool addSharedMapErrors(FixedCameraResult* result, const std::vector<MapLine>& used_lines) const;
  // The map as inserted with the lines beyond the depth range (cached per keyframe generation).
  const LineMap& unadjustedMap() const;
  const LineMap& extendedMap() const;  // computeExtendedMap at the map in use's corrections (cached likewise)
  std::vector<FloorObservation> floorObservations(const RgbdFrame& frame, const std::vector<Line3d>& lines,
                                                  const std::vector<UnliftedSegment>& unlifted);

  SurveyOptions options_;
  RgbdLineExtractor extractor_;
  LineMap map_;
  KeyframeSelector keyframes_;
  std::map<std::string, std::unique_ptr<FixedCamera>> cameras_;
  std::map<std::string, double> last_fixed_stamp_;
  std::vector<Keyframe> keyframe_data_;
  // The keyframes' depth (options_.occlusion), none when disabled; replaced by the adjustment's (corrected poses).
  mutable std::shared_ptr<SurfaceVoxels> surfaces_;
  // The adjusted map and corrections, a cache of keyframes_ (current while adjusted_ is true; has_adjustment_: one
  // was computed, perhaps before the newest keyframes).
  mutable LineMap adjusted_map_;
  mutable std::vector<PoseCorrection> corrections_;
  mutable bool adjusted_ = false;
  mutable bool has_adjustment_ = false;
  mutable LineMap unadjusted_map_;  // map_ with the floor lines, current at unadjusted_generation_
  mutable LineMap extended_map_;    // computeExtendedMap of the map in use, current at extended_generation_
  mutable uint64_t extended_generation_ = UINT64_MAX;
  mutable uint64_t unadjusted_generation_ = UINT64_MAX;
  uint64_t keyframe_generation_ = 0;  // counts keyframes added and resets
  uint64_t reset_generation_ = 0;     // keyframe_generation_ at the last reset()
  bool recording_started_ = false;    // startRecording() came after the last keyframe
  mutable SurveyStats stats_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_SURVEY_H
