#include "insitu_calibration/survey/survey.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <utility>

#include "insitu_calibration/cpu_time.h"
#include "insitu_calibration/refine/refinement.h"
#include "insitu_calibration/survey/uncertainty_budget.h"
#include "insitu_calibration/survey/view_ambiguity.h"

namespace insitu_calibration
{
namespace
{
// The free-space grid of a keyframe (triangulated lines): 16 px cells (about 3 deg of the Xtion's view), from every
// 4th depth pixel.
constexpr double kFreeSpaceCellPx = 16.0;
constexpr int kFreeSpacePixelStep = 4;

// What the adjustment needs of a keyframe: its tf pose and its lines in the camera frame with their 2D segments.
Keyframe toKeyframe(const RgbdFrame& frame, const std::vector<Line3d>& lines, std::vector<FloorObservation> floor)
{
  Keyframe kf;
  kf.stamp = frame.stamp;
  kf.T_map_camera = frame.T_map_camera;
  kf.focal_px = frame.camera.intrinsics.fx;
  kf.image_width = frame.camera.width;
  kf.image_height = frame.camera.height;
  const Eigen::Isometry3d camera_from_map = frame.T_map_camera.inverse();
  for (const auto& l : lines)
  {
    KeyframeLine k;
    k.line = l;
    k.line.transform(camera_from_map);
    k.line.sensor = Eigen::Vector3d::Zero();
    k.image_a = frame.camera.normalize(l.image.a);
    k.image_b = frame.camera.normalize(l.image.b);
    kf.lines.push_back(k);
  }
  kf.floor = std::move(floor);
  return kf;
}

// Whether the calibration uses a map line with enough support: its observations' spread within the limit, or fused
// (a fused line's observations are spread by their depth errors; its consistency test stands for the spread's).
std::vector<Segment3d> segmentsOf(const std::vector<MapLine>& lines)
{
  std::vector<Segment3d> out;
  for (const auto& line : lines)
    out.push_back({line.a(), line.b()});
  return out;
}

bool usedByCalibration(const MapLine& line, const SurveyOptions& o)
{
  return line.fused || line.spread() <= o.max_map_spread_m;
}

// The lines beyond the depth range (floor lines, ceiling lines, then triangulated lines), added to a map of depth
// lines.
void addLinesBeyondDepth(const std::vector<Keyframe>& keyframes, const std::vector<PoseCorrection>& corrections,
                         const SurveyOptions& o, LineMap* map)
{
  for (const auto& line : confirmFloorLines(keyframes, corrections, map->lines(), o.floor))
    map->add(line);
  // A ceiling line is left out only where a depth line the calibration will use holds it (a line seen once, or
  // spread, would leave the edge to neither).
  std::vector<MapLine> used;
  for (const auto& line : map->lines(o.min_map_support))
    if (usedByCalibration(line, o))
      used.push_back(line);
  for (const auto& line : confirmCeilingLines(keyframes, corrections, used, o.ceiling, o.floor.floor_height_m))
    map->add(line);
  TriangulatedLineOptions triangulated = o.triangulated;
  triangulated.floor_height_m = o.floor.floor_height_m;
  for (const auto& line : triangulateLines(keyframes, corrections, map->lines(), triangulated))
    map->add(line);
}

// Whether keyframes keep their ceiling candidates: for the map in use or for the retry's extended map.
bool keepsCeilingObservations(const SurveyOptions& o)
{
  return o.ceiling.enabled || (o.extended_retry.enabled && o.extended_retry.ceiling_lines);
}

// Whether the extraction keeps the RGB segments without a depth line (the lines beyond the depth range need them).
bool keepsUnlifted(const SurveyOptions& o)
{
  return o.floor.enabled || keepsCeilingObservations(o) || o.triangulated.enabled;
}

bool beyondDepth(const SurveyOptions& o)
{
  return o.floor.enabled || o.ceiling.enabled || o.triangulated.enabled;
}

// Whether both end points' rays of a 2D segment (normalised coordinates) rise in the map frame.
bool aboveHorizon(const FloorObservation& obs, const Eigen::Isometry3d& T_map_camera)
{
  auto rises = [&](const Eigen::Vector2d& p) {
    return (T_map_camera.linear() * Eigen::Vector3d(p.x(), p.y(), 1.0)).z() > 0.0;
  };
  return rises(obs.image_a) && rises(obs.image_b);
}

// The frame's ceiling candidates (ceiling_lines.h): 2D segments above the horizon whose 3D line the map refuses as
// too uncertain (its height and range from that line) or that have none (from their depth samples, if any).
std::vector<CeilingObservation> ceilingObservations(const RgbdFrame& frame, const std::vector<Line3d>& lines,
                                                    const std::vector<UnliftedSegment>& unlifted,
                                                    const LineMapOptions& map)
{
  std::vector<CeilingObservation> out;
  for (const auto& l : lines)
  {
    CeilingObservation c{{frame.camera.normalize(l.image.a), frame.camera.normalize(l.image.b)}};
    if (l.sigma_m > map.max_sigma_m && aboveHorizon(c.image, frame.T_map_camera))
    {
      c.has_depth = true;
      c.depth_height_m = 0.5 * (l.a.z() + l.b.z());
      c.range_m = l.range_m;
      out.push_back(c);
    }
  }
  for (const auto& u : unlifted)
  {
    CeilingObservation c{{frame.camera.normalize(u.segment.a), frame.camera.normalize(u.segment.b)}};
    if (!aboveHorizon(c.image, frame.T_map_camera))
      continue;
    std::vector<std::pair<double, double>> depths;  // (range, height) per sample
    for (const auto& sample : u.samples)
    {
      const Eigen::Vector2d p = frame.camera.normalize(sample.pixel);
      const Eigen::Vector3d point = frame.T_map_camera * (sample.depth_m * Eigen::Vector3d(p.x(), p.y(), 1.0));
      depths.emplace_back(sample.depth_m, point.z());
    }
    if (depths.size() >= 5)
    {
      std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
      c.has_depth = true;
      c.range_m = depths[depths.size() / 2].first;
      c.depth_height_m = depths[depths.size() / 2].second;
    }
    out.push_back(c);
  }
  return out;
}

bool adjusting(const SurveyOptions& o)
{
  return o.localization_sigma_m > 0.0 && o.localization_sigma_deg > 0.0;
}

// The final check tells floor lines as the floor lines' extraction does (floor plane and height tolerance).
void useSurveyFloor(const FloorLineOptions& floor, FixedCameraOptions& cameras)
{
  cameras.explanation.floor_height_m = floor.floor_height_m;
  cameras.explanation.floor_tolerance_m = 0.5 * floor.min_edge_height_m;
}
}  // namespace

Survey::Survey(const std::vector<FixedCameraConfig>& cameras, const SurveyOptions& options)
    : options_(options),
      extractor_(options.rgbd),
      map_(options.map),
      keyframes_(options.keyframes),
      adjusted_map_(options.map),
      unadjusted_map_(options.map),
      extended_map_(options.map)
{
  options_.adjustment.localization_sigma_m = options.localization_sigma_m;
  options_.adjustment.localization_sigma_deg = options.localization_sigma_deg;
  options_.adjustment.localization_correlation_s = options.localization_correlation_s;
  useSurveyFloor(options_.floor, options_.cameras);
  for (const auto& config : cameras)
    cameras_.emplace(config.name, std::make_unique<FixedCamera>(config, options_.cameras));
  if (options_.occlusion.enabled)
    surfaces_ = std::make_shared<SurfaceVoxels>(options_.occlusion);
}

Expected<bool> Survey::addRgbdFrame(const RgbdFrame& frame, const std::optional<Eigen::Isometry3d>& T_odom_camera,
                                    std::vector<Segment2d>* keyframe_segments)
{
  ++stats_.frames;
  if (const Status valid = validateFrame(frame); !valid)
  {
    ++stats_.skipped;
    return valid.error();
  }
  if (!keyframes_.accept(frame.T_map_camera, frame.stamp))
    return false;
  std::vector<UnliftedSegment> unlifted;
  const auto lines =
      extractor_.extract(frame, nullptr, keepsUnlifted(options_) ? &unlifted : nullptr, keyframe_segments);
  if (!lines)
  {
    ++stats_.skipped;
    return lines.error();
  }
  map_.insert(*lines);
  std::vector<Eigen::Vector3f> depth_samples;
  if (surfaces_)
  {
    if (surfaces_.use_count() > 1)  // a calibration holds these (the node's, running unlocked): copy on write
      surfaces_ = std::make_shared<SurfaceVoxels>(*surfaces_);
    surfaces_->insertDepth(frame);
    if (options_.occlusion.follow_adjustment && insitu_calibration::adjusting(options_))  // see computeAdjustment
      depth_samples = surfaces_->depthSamples(frame, options_.occlusion.kept_cell_m);
  }
  keyframe_data_.push_back(toKeyframe(frame, *lines, floorObservations(frame, *lines, unlifted)));
  if (keepsCeilingObservations(options_))
    keyframe_data_.back().ceiling = ceilingObservations(frame, *lines, unlifted, options_.map);
  keyframe_data_.back().surface = std::move(depth_samples);
  if (options_.triangulated.enabled)
  {
    for (const auto& u : unlifted)
      keyframe_data_.back().rgb.push_back({frame.camera.normalize(u.segment.a), frame.camera.normalize(u.segment.b)});
    keyframe_data_.back().depth_grid = depthRangeGrid(frame, kFreeSpaceCellPx, kFreeSpacePixelStep);
  }
  keyframe_data_.back().starts_recording = std::exchange(recording_started_, false);
  keyframe_data_.back().has_odometry = T_odom_camera.has_value();
  if (T_odom_camera)
    keyframe_data_.back().T_odom_camera = *T_odom_camera;
  adjusted_ = false;
  ++keyframe_generation_;
  ++stats_.keyframes;
  stats_.lines += lines->size();
  return true;
}

Expected<bool> Survey::addFixedImage(const std::string& camera, const cv::Mat& image, double stamp)
{
  if (!hasCamera(camera))
    return Error(ErrorCode::kInvalidInput, "unknown camera '" + camera + "'");
  // One image per period is enough for the median; a clock that went back (a bag restarted) starts over.
  const auto last = last_fixed_stamp_.find(camera);
  if (last != last_fixed_stamp_.end() && stamp >= last->second && stamp - last->second < options_.fixed_image_period_s)
    return false;
  if (const Status added = cameras_.at(camera)->addImage(image); !added)
    return added.error();
  last_fixed_stamp_[camera] = stamp;
  return true;
}

std::vector<FloorObservation> Survey::floorObservations(const RgbdFrame& frame, const std::vector<Line3d>& lines,
                                                        const std::vector<UnliftedSegment>& unlifted)
{
  std::vector<FloorObservation> out;
  FloorCandidate candidate;
  for (const auto& u : unlifted)
  {
    FloorObservation obs{frame.camera.normalize(u.segment.a), frame.camera.normalize(u.segment.b)};
    if (!intersectFloor(obs, frame.T_map_camera, frame.camera.intrinsics.fx, options_.floor, &candidate))
      continue;
    const FloorDepth depth = floorDepthOf(u.samples, frame.camera, frame.T_map_camera, options_.floor);
    if (depth == FloorDepth::kOffFloor)
    {
      ++stats_.floor_refused;
      continue;
    }
    obs.depth_on_floor = depth == FloorDepth::kOnFloor;
    out.push_back(obs);
  }
  // Depth lines on the floor too uncertain for the map (the floor at a slant): placed by the ray-plane intersection,
  // their depth confirming them.
  if (options_.floor.depth_confirmation)
    for (const auto& l : lines)
    {
      const FloorObservation obs{frame.camera.normalize(l.image.a), frame.camera.normalize(l.image.b), true};
      if (l.sigma_m > options_.map.max_sigma_m && depthLineOnFloor(l, options_.floor) &&
          intersectFloor(obs, frame.T_map_camera, frame.camera.intrinsics.fx, options_.floor, &candidate))
        out.push_back(obs);
    }
  stats_.floor_candidates += out.size();
  return out;
}

const LineMap& Survey::unadjustedMap() const
{
  if (!beyondDepth(options_))
    return map_;
  if (unadjusted_generation_ != keyframe_generation_)
  {
    unadjusted_map_ = map_;
    addLinesBeyondDepth(keyframe_data_, {}, options_, &unadjusted_map_);
    unadjusted_generation_ = keyframe_generation_;
  }
  return unadjusted_map_;
}

bool Survey::adjusting() const
{
  return insitu_calibration::adjusting(options_) && !keyframe_data_.empty();
}

const LineMap& Survey::lineMap() const
{
  if (!adjusting())
    return unadjustedMap();
  if (!adjusted_)
    adjustMap();
  return adjusted_map_;
}

const LineMap& Survey::latestLineMap() const
{
  if (!adjusting())
    return unadjustedMap();
  return has_adjustment_ ? adjusted_map_ : map_;
}

namespace
{
// The map's merge and association tolerances widened by what the remaining pose errors (scale times the
// localiser's: the difference of two keyframes' errors, at a typical range) can add.
LineMapOptions widenedMapOptions(const SurveyOptions& o, double scale)
{
  LineMapOptions m = o.map;
  if (scale <= 0.0)
    return m;
  const double typical_range_m = 3.0;
  const double sigma_rad = o.localization_sigma_deg * M_PI / 180.0;
  const double offset = scale * std::sqrt(2.0) * (o.localization_sigma_m + sigma_rad * typical_range_m);
  m.max_lateral_m += scale * std::sqrt(2.0) * o.localization_sigma_m;
  m.max_lateral_per_m += scale * std::sqrt(2.0) * sigma_rad;
  m.max_distance_m += offset;
  m.depth_floor_m = std::hypot(m.depth_floor_m, offset / std::max(1.0, m.depth_sigmas));
  m.max_angle_deg += scale * std::sqrt(2.0) * o.localization_sigma_deg;
  return m;
}

// The lines without a parallel neighbour within distance_m (stripes, a frame's two sides): while the poses are
// centimetres off, an observation of one of them may be associated with the other, and a wrong association that
// all of a neighbourhood's keyframes share moves them together.
std::vector<MapLine> unambiguousLines(const std::vector<MapLine>& lines, double distance_m, double angle_deg)
{
  std::vector<MapLine> out;
  const double cos_limit = std::cos(angle_deg * M_PI / 180.0);
  for (size_t i = 0; i < lines.size(); ++i)
  {
    bool ambiguous = false;
    for (size_t j = 0; j < lines.size() && !ambiguous; ++j)
    {
      if (i == j || std::abs(lines[i].direction.dot(lines[j].direction)) < cos_limit)
        continue;
      const Eigen::Vector3d r = 0.5 * (lines[j].a() + lines[j].b()) - lines[i].point;
      const double s = r.dot(lines[i].direction);
      const double half = 0.5 * lines[j].length();
      ambiguous =
          (r - s * lines[i].direction).norm() < distance_m && s + half > lines[i].s_min && s - half < lines[i].s_max;
    }
    if (!ambiguous)
      out.push_back(lines[i]);
  }
  return out;
}
}  // namespace

MapAdjustment Survey::computeAdjustment(const std::vector<Keyframe>& keyframes, const SurveyOptions& options,
                                        uint64_t generation)
{
  const double start = threadCpuMs();
  std::vector<PoseCorrection> corrections(keyframes.size());
  size_t used = 0, dropped = 0;
  // Graduated: the first rounds merge and associate with tolerances widened by the pose errors that may remain
  // (at tf's tolerances the observations of one edge from keyframes with different errors stay apart, and the
  // adjustment cannot tie those keyframes together), the last at the map's own.
  for (int round = 0; round < options.adjustment_rounds; ++round)
  {
    const double scale =
        options.adjustment_rounds > 1 ? 1.0 - static_cast<double>(round) / (options.adjustment_rounds - 1) : 0.0;
    const LineMapOptions widened = widenedMapOptions(options, scale);
    const LineMap current = rebuildLineMap(keyframes, corrections, widened);
    // Every line seen twice, whatever its spread: the lines whose observations disagree because the poses do are
    // the ones that tell the poses apart (the robust loss and the outlier test keep wrong merges out).
    std::vector<MapLine> lines = current.lines(options.min_map_support);
    if (scale > 0.0)
      lines = unambiguousLines(lines, 2.0 * (widened.max_lateral_m + 3.0 * widened.max_lateral_per_m),
                               widened.max_angle_deg);
    std::vector<AdjustedLine> starts;
    for (const auto& line : lines)
      starts.push_back({line.point, line.direction});
    const auto observations = associateObservations(keyframes, corrections, lines, widened);
    const auto result = adjustLineMap(keyframes, starts, observations, corrections, options.adjustment);
    if (!result)
      break;  // nothing to adjust: the map stays as tf put it
    corrections = result->corrections;
    used = observations.size();
    dropped = result->dropped;
  }
  MapAdjustment out{
      rebuildLineMap(keyframes, corrections, options.map), corrections, used, dropped, 0.0, generation, nullptr};
  addLinesBeyondDepth(keyframes, corrections, options, &out.map);
  if (options.occlusion.enabled && options.occlusion.follow_adjustment)
    out.surfaces = std::make_shared<SurfaceVoxels>(rebuildSurfaces(keyframes, corrections, options.occlusion));
  out.cpu_ms = cpuMsSince(start);
  return out;
}

bool Survey::installAdjustment(MapAdjustment adjustment)
{
  if (adjustment.generation < reset_generation_ || adjustment.generation > keyframe_generation_)
    return false;
  cacheAdjustment(std::move(adjustment));
  return true;
}

void Survey::cacheAdjustment(MapAdjustment adjustment) const
{
  double sum_m = 0.0, sum_rad = 0.0;
  for (const auto& c : adjustment.corrections)
  {
    sum_m += c.x * c.x + c.y * c.y;
    sum_rad += c.yaw * c.yaw;
  }
  const double n = std::max<size_t>(1, adjustment.corrections.size());
  stats_.adjusted_observations = adjustment.observations;
  stats_.dropped_observations = adjustment.dropped;
  stats_.mean_correction_m = std::sqrt(sum_m / n);
  stats_.mean_correction_deg = std::sqrt(sum_rad / n) * 180.0 / M_PI;
  stats_.adjustment_cpu_ms = adjustment.cpu_ms;
  adjusted_ = adjustment.generation == keyframe_generation_;
  has_adjustment_ = true;
  adjusted_map_ = std::move(adjustment.map);
  if (adjustment.surfaces)
  {  // keyframes that came after the adjustment's, at tf's poses
    for (size_t k = adjustment.corrections.size(); k < keyframe_data_.size(); ++k)
      adjustment.surfaces->insertSamples(keyframe_data_[k].T_map_camera, keyframe_data_[k].surface);
    surfaces_ = std::move(adjustment.surfaces);
  }
  corrections_ = std::move(adjustment.corrections);
}

void Survey::adjustMap() const
{
  cacheAdjustment(computeAdjustment(keyframe_data_, options_, keyframe_generation_));
}

std::vector<PoseCorrection> Survey::poseCorrections() const
{
  lineMap();
  return adjusted_ ? corrections_ : std::vector<PoseCorrection>(keyframe_data_.size());
}

namespace
{
LocaliserErrorModel localiserErrorModel(const SurveyOptions& o)
{
  return {o.localization_sigma_m, o.localization_sigma_deg, o.localization_correlation_s};
}
}  // namespace

MapPlacementUncertainty Survey::placementOver(const std::vector<size_t>& selected) const
{
  MapPlacementUncertainty out = placementOverKeyframes(keyframe_data_, selected, localiserErrorModel(options_));
  if (!adjusting())
    out.sigma_m = out.sigma_deg = 0.0;
  return out;
}

MapPlacementUncertainty Survey::mapPlacement() const
{
  std::vector<size_t> every(keyframe_data_.size());
  std::iota(every.begin(), every.end(), size_t{0});
  return placementOver(every);
}

MapPlacementUncertainty Survey::mapPlacementOf(const std::vector<const MapLine*>& lines) const
{
  return placementOver(keyframesObserving(keyframe_data_, lines));
}

// The map it was matched to was adjusted for the assumed error, and the adjustment moves the keyframes by a few
// millimetres even where tf is exact: on a simulated survey such a camera was accepted with tf's poses as they are,
// and refused with any assumed error, 5 mm / 0.1 deg too (docs/measurements.md, "The refusal's localiser note
// corrected").
Error withAssumedLocaliser(const Error& refusal, const SurveyOptions& o)
{
  if (refusal.code() != ErrorCode::kDegenerate || refusal.message().rfind(kWeaklyDeterminedRefusal, 0) != 0 ||
      !adjusting(o))
    return refusal;
  char note[512];
  std::snprintf(note, sizeof(note),
                "; the map was adjusted for the localiser error the survey assumes (localization_sigma_m %g, "
                "localization_sigma_deg %g), which moves the keyframes by a few millimetres even where tf is exact: "
                "if the robot's poses are exact to about a millimetre (motion capture, a simulator), "
                "calibrate_survey --localization-sigma 0,0 takes them as they are",
                o.localization_sigma_m, o.localization_sigma_deg);
  return Error(refusal.code(), refusal.message() + note);
}

Expected<FixedCameraResult> Survey::calibrate(const std::string& name, const std::string& world_frame)
{
  if (!hasCamera(name))
    return Error(ErrorCode::kInvalidInput, "unknown camera '" + name + "'");
  const LineMap& in_use = lineMap();  // adjusts the map (and the surfaces with it) if new keyframes came
  // The camera holds the voxels only while it calibrates: a holder makes the next keyframe copy them.
  camera(name).setOccluders(surfaces_);
  useSurveyCeiling(camera(name));
  CalibrationMap used;
  auto result = calibrateWithExtendedRetry(
      camera(name), world_frame, calibrationMapOf(in_use),
      [this]() { return extendedRetryAdds(options_) ? calibrationMapOf(extendedMap(), true) : CalibrationMap{}; },
      &used);
  camera(name).setOccluders(nullptr);
  if (!result)
    return withAssumedLocaliser(result.error(), options_);
  if (addMapPlacement(&*result, used.lines))
    camera(name).setCalibration(result->file);
  return result;
}

void Survey::useSurveyCeiling(FixedCamera& camera) const
{
  FixedCameraOptions options = camera.options();
  const auto ceiling = measureCeilingHeight(keyframe_data_, options_.ceiling, options_.floor.floor_height_m);
  options.explanation.ceiling_height_m = ceiling ? std::optional<double>(ceiling->height_m) : std::nullopt;
  camera.setOptions(options);
}

CalibrationMap Survey::calibrationMapOf(const LineMap& map, bool extended) const
{
  CalibrationMap out;
  out.lines = usedLinesOf(map);
  out.segments = segmentsOf(out.lines);
  out.sigmas = sigmasOf(out.lines);
  out.extended = extended;
  return out;
}

LineMap Survey::computeExtendedMap(const std::vector<Keyframe>& keyframes, std::vector<PoseCorrection> corrections,
                                   const SurveyOptions& options)
{
  const SurveyOptions extended = extendedMapOptions(options);
  corrections.resize(keyframes.size());  // keyframes after the last adjustment: as tf gave them
  LineMap map = rebuildLineMap(keyframes, corrections, extended.map);
  addLinesBeyondDepth(keyframes, corrections, extended, &map);
  return map;
}

const LineMap& Survey::extendedMap() const
{
  if (extended_generation_ != keyframe_generation_)
  {
    extended_map_ = computeExtendedMap(keyframe_data_, poseCorrections(), options_);
    extended_generation_ = keyframe_generation_;
  }
  return extended_map_;
}

SurveyOptions extendedMapOptions(const SurveyOptions& options)
{
  SurveyOptions out = options;
  out.map.max_fusion_sigma_m = std::max(out.map.max_fusion_sigma_m, options.extended_retry.max_fusion_sigma_m);
  out.ceiling.enabled = out.ceiling.enabled || options.extended_retry.ceiling_lines;
  return out;
}

bool extendedRetryAdds(const SurveyOptions& options)
{
  const auto& retry = options.extended_retry;
  return retry.enabled && (retry.max_fusion_sigma_m > options.map.max_fusion_sigma_m ||
                           (retry.ceiling_lines && !options.ceiling.enabled));
}

bool extendedRetryWorthwhile(const Error& refusal)
{
  const ErrorCode code = refusal.code();
  // Not the ambiguity test's refusal: the map in use found two cameras explaining the image alike, and the extended
  // map's less certain lines are no ground to pick one (a repeating view was accepted a period off so, 2026-12-07).
  return (code == ErrorCode::kNotEnoughData || code == ErrorCode::kDegenerate || code == ErrorCode::kNoSolution) &&
         refusal.message().find(kNoImageRefusal) == std::string::npos && !isAmbiguityRefusal(refusal);
}

namespace
{
constexpr const char* kExtendedMap = "the map with its extensions (fused uncertain depth lines, ceiling lines)";

// A refusal's reason without its numbers and advice: up to its first ':' or ' ('.
std::string firstClause(const std::string& message)
{
  return message.substr(0, std::min(message.find(':'), message.find(" (")));
}

// The first refusal with the retry's reason inserted before its advice ("What to do: ..."), which is for the map in
// use and stays last.
Error withExtendedAttempt(const Error& first, const Error& second)
{
  const std::string advice_mark = " What to do:";
  const std::string reason = second.message().substr(0, second.message().find(advice_mark));
  const std::string note = std::string(" (tried again on ") + kExtendedMap + ": " + reason + ")";
  std::string message = first.message();
  const size_t advice = message.find(advice_mark);
  message.insert(advice == std::string::npos ? message.size() : advice, note);
  return Error(first.code(), message);
}
}  // namespace

Expected<FixedCameraResult> calibrateWithExtendedRetry(FixedCamera& camera, const std::string& world_frame,
                                                       const CalibrationMap& map,
                                                       const std::function<CalibrationMap()>& extended,
                                                       CalibrationMap* used)
{
  auto result = camera.calibrate(map.segments, world_frame, map.sigmas);
  if (used)
    *used = map;
  // A camera calibrated from its correspondence file does not use the map: another map cannot turn its refusal.
  if (result || !camera.config().correspondence_file.empty() || !extendedRetryWorthwhile(result.error()))
    return result;
  const CalibrationMap second_map = extended();
  if (second_map.segments.empty())
    return result;
  auto second = camera.calibrate(second_map.segments, world_frame, second_map.sigmas);
  if (!second)
    return withExtendedAttempt(result.error(), second.error());
  second->summary += std::string("; on ") + kExtendedMap + ": the map in use refused it (" +
                     firstClause(result.error().message()) + ")";
  if (second->file.quality)
    second->file.quality->extra["extended_map"] = 1.0;
  if (used)
    *used = second_map;
  return second;
}

bool Survey::addMapPlacement(FixedCameraResult* result, const std::vector<MapLine>& used_lines) const
{
  // The matched lines' own part first (what the checks used): the uncertainty budget's first term.
  if (result->file.quality && result->calibration.uncertainty.available)
  {
    result->file.quality->extra[kSigmaLinesPositionKey] = result->calibration.uncertainty.position_m;
    result->file.quality->extra[kSigmaLinesRotationKey] = result->calibration.uncertainty.rotation_deg;
  }
  const bool shared = addSharedMapErrors(result, used_lines);
  // The whole map may be off by the placement: a shift of the camera, and a turn about the survey's centre that
  // turns the camera and moves it by the turn times its horizontal distance from the centre.
  const MapPlacementUncertainty placement = mapPlacement();
  CameraUncertainty& u = result->calibration.uncertainty;
  if (!u.available || !(placement.sigma_m > 0.0 || placement.sigma_deg > 0.0))
    return shared;
  const double placement_m = placement.atPoint(result->calibration.camera.pose().center());
  u.position_m = std::hypot(u.position_m, placement_m);
  u.rotation_deg = std::hypot(u.rotation_deg, placement.sigma_deg);
  if (result->file.quality)
  {
    auto& extra = result->file.quality->extra;
    extra["sigma_position_m"] = u.position_m;
    extra["sigma_rotation_deg"] = u.rotation_deg;
    extra["sigma_map_placement_m"] = std::hypot(placement.sigma_m, placement.sigma_m);
    extra[kSigmaPlacementRotationKey] = placement.sigma_deg;
    extra[kSigmaPlacementAtCameraKey] = placement_m;
  }
  return true;
}

namespace
{
// The error a map line's observations share (Line3d::sigma_systematic_m: the depth registration's uncertainty at
// the edge), which their number does not reduce: their mean, weighted as the refit weighs them.
double sharedSigma(const MapLine& line)
{
  double sum = 0.0, weight = 0.0;
  for (const auto& o : line.observations)
    if (o.sigma_depth > 0.0)
    {
      const double w = 1.0 / (o.sigma_depth * o.sigma_depth);
      sum += w * o.sigma_systematic;
      weight += w;
    }
  return weight > 0.0 ? sum / weight : 0.0;
}

// A map line's errors that all its observations share, as independent rigid moves at one sigma: the floor
// (min_map_line_sigma_m) in both directions across it, and the registration's (sharedSigma) where that error acts,
// along the rays it was seen on: in the observations' interpretation planes, across the line (in both directions
// when the sensor is unknown).
std::vector<Eigen::Vector3d> sharedErrorModes(const MapLine& line, double floor_m)
{
  const Eigen::Vector3d u = line.direction.normalized();
  const Eigen::Vector3d e1 = u.unitOrthogonal(), e2 = u.cross(e1);
  std::vector<Eigen::Vector3d> modes = {floor_m * e1, floor_m * e2};
  const double shared = sharedSigma(line);
  if (!(shared > 0.0))
    return modes;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (const auto& o : line.observations)
    normal += normal.dot(o.normal) < 0.0 ? -o.normal : o.normal;
  const Eigen::Vector3d along_rays = u.cross(normal);
  if (along_rays.norm() > 1e-6)
    modes.push_back(shared * along_rays.normalized());
  else
    modes.insert(modes.end(), {shared * e1, shared * e2});
  return modes;
}

// The used map line a correspondence's world points were sampled from (they lie on it), or none.
const MapLine* sourceLineOf(const LineCorrespondence& c, const std::vector<MapLine>& used)
{
  if (c.world.empty())
    return nullptr;
  const auto on = [](const MapLine& line, const Eigen::Vector3d& x) {
    const Eigen::Vector3d d = x - line.point;
    const double s = d.dot(line.direction);
    return (d - s * line.direction).norm() < 1e-6 && s > line.s_min - 1e-6 && s < line.s_max + 1e-6;
  };
  for (const MapLine& line : used)
    if (on(line, c.world.front()) && on(line, c.world.back()))
      return &line;
  return nullptr;
}
}  // namespace

std::vector<const MapLine*> Survey::matchedMapLines(const FixedCameraResult& result,
                                                    const std::vector<MapLine>& used_lines)
{
  std::vector<const MapLine*> out;
  const auto& inlier = result.calibration.inlier_lines;
  for (size_t k = 0; k < result.correspondences.lines.size(); ++k)
    if (k < inlier.size() && inlier[k])
      out.push_back(sourceLineOf(result.correspondences.lines[k], used_lines));
  return out;
}

bool Survey::addSharedMapErrors(FixedCameraResult* result, const std::vector<MapLine>& used) const
{
  CameraCalibration& c = result->calibration;
  CameraUncertainty& u = c.uncertainty;
  if (!options_.shared_map_errors_in_sigma || !u.available || !c.refinement)
    return false;
  // The lines the final refinement used, each with its map line's shared errors.
  const std::vector<const MapLine*> lines = matchedMapLines(*result, used);
  CorrespondenceSet inliers = result->correspondences;
  inliers.lines.clear();
  std::vector<std::vector<Eigen::Vector3d>> modes;
  for (size_t k = 0, i = 0; k < result->correspondences.lines.size(); ++k)
    if (k < c.inlier_lines.size() && c.inlier_lines[k])
    {
      const MapLine* line = lines[i++];
      inliers.lines.push_back(result->correspondences.lines[k]);
      modes.push_back(line ? sharedErrorModes(*line, options_.min_map_line_sigma_m) : std::vector<Eigen::Vector3d>());
    }
  const std::string& name = result->correspondences.camera_name;
  RefinementOptions refinement =
      (hasCamera(name) ? camera(name).matcherOptions() : options_.cameras.matcher).calibration.refinement;
  refinement.estimate_distortion = c.distortion_estimated;
  const Expected<CameraUncertainty> shared = propagateWorldLineErrors(inliers, c.camera, refinement, modes);
  if (!shared)
    return false;
  u.fx = std::hypot(u.fx, shared->fx);
  u.fy = std::hypot(u.fy, shared->fy);
  u.cx = std::hypot(u.cx, shared->cx);
  u.cy = std::hypot(u.cy, shared->cy);
  u.lambda = std::hypot(u.lambda, shared->lambda);
  u.position_m = std::hypot(u.position_m, shared->position_m);
  u.rotation_deg = std::hypot(u.rotation_deg, shared->rotation_deg);
  if (result->file.quality)
  {
    auto& extra = result->file.quality->extra;
    extra["sigma_fx_px"] = u.fx;
    extra["sigma_fy_px"] = u.fy;
    extra["sigma_cx_px"] = u.cx;
    extra["sigma_cy_px"] = u.cy;
    extra["sigma_lambda"] = u.lambda;
    extra["sigma_position_m"] = u.position_m;
    extra["sigma_rotation_deg"] = u.rotation_deg;
    extra["sigma_shared_map_fx_px"] = shared->fx;
    extra[kSigmaSharedMapPositionKey] = shared->position_m;
    extra[kSigmaSharedMapRotationKey] = shared->rotation_deg;
  }
  return true;
}

std::vector<MapLine> Survey::usedLinesOf(const LineMap& map) const
{
  std::vector<MapLine> out;
  for (const auto& line : map.lines(options_.min_map_support))
    if (usedByCalibration(line, options_))
      out.push_back(line);
  return out;
}

std::vector<MapLine> Survey::usedMapLines() const
{
  return usedLinesOf(lineMap());
}

std::vector<double> Survey::sigmasOf(const std::vector<MapLine>& used) const
{
  std::vector<double> out;
  // The map line's standard error predicted from its observations (it falls with their number, where the spread
  // does not: a line seen 20 times counted as much as one seen twice), with the floor for the errors the
  // observations share (an edge's depth bias seen from similar viewpoints) and, with shared_map_line_sigma, their
  // shared registration error; the spread when nothing is predicted.
  for (const auto& line : used)
  {
    const double shared =
        std::hypot(options_.min_map_line_sigma_m, options_.shared_map_line_sigma ? sharedSigma(line) : 0.0);
    out.push_back(line.sigma() > 0.0 ? std::hypot(shared, line.sigma()) : std::max(shared, line.spread()));
  }
  return out;
}

std::vector<double> Survey::mapLineSigmas() const
{
  return sigmasOf(usedMapLines());
}

std::vector<double> Survey::latestMapLineSigmas() const
{
  return sigmasOf(usedLinesOf(latestLineMap()));
}

std::vector<Segment3d> Survey::mapSegments() const
{
  return segmentsOf(usedMapLines());
}

std::vector<Segment3d> Survey::latestMapSegments() const
{
  return segmentsOf(usedLinesOf(latestLineMap()));
}

std::vector<std::string> Survey::cameraNames() const
{
  std::vector<std::string> names;
  for (const auto& [name, camera] : cameras_)
    names.push_back(name);
  return names;
}

void Survey::setCameraOptions(const FixedCameraOptions& options)
{
  const size_t median_images = options_.cameras.median_images;
  options_.cameras = options;
  options_.cameras.median_images = median_images;
  useSurveyFloor(options_.floor, options_.cameras);
  for (auto& [name, camera] : cameras_)
    camera->setOptions(options_.cameras);
}

void Survey::startRecording()
{
  keyframes_.reset();
  recording_started_ = !keyframe_data_.empty();
}

void Survey::reset()
{
  recording_started_ = false;
  map_.clear();
  keyframes_.reset();
  keyframe_data_.clear();
  if (surfaces_)
    surfaces_ = std::make_shared<SurfaceVoxels>(options_.occlusion);
  adjusted_map_.clear();
  corrections_.clear();
  adjusted_ = false;
  has_adjustment_ = false;
  reset_generation_ = ++keyframe_generation_;
  last_fixed_stamp_.clear();
  for (auto& [name, camera] : cameras_)
    camera->reset();
  stats_ = SurveyStats();
}

}  // namespace insitu_calibration
