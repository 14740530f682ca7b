#include "insitu_calibration/survey/survey.h"

#include <algorithm>
#include <cmath>

#include "insitu_calibration/cpu_time.h"

namespace insitu_calibration
{
namespace
{
// What the adjustment needs of a keyframe: its tf pose and its lines in the camera frame with their 2D segments.
Keyframe toKeyframe(const RgbdFrame& frame, const std::vector<Line3d>& lines)
{
  Keyframe kf;
  kf.stamp = frame.stamp;
  kf.T_map_camera = frame.T_map_camera;
  kf.focal_px = frame.camera.intrinsics.fx;
  const Eigen::Isometry3d camera_from_map = frame.T_map_camera.inverse();
  for (const auto& l : lines)
  {
    KeyframeLine k;
    k.line = l;
    k.line.a = camera_from_map * l.a;
    k.line.b = camera_from_map * l.b;
    k.line.sensor = Eigen::Vector3d::Zero();
    k.image_a = frame.camera.normalize(l.image.a);
    k.image_b = frame.camera.normalize(l.image.b);
    kf.lines.push_back(k);
  }
  return kf;
}

bool adjusting(const SurveyOptions& o)
{
  return o.localization_sigma_m > 0.0 && o.localization_sigma_deg > 0.0;
}
}  // namespace

Survey::Survey(const std::vector<FixedCameraConfig>& cameras, const SurveyOptions& options)
    : options_(options),
      extractor_(options.rgbd),
      map_(options.map),
      keyframes_(options.keyframes),
      adjusted_map_(options.map)
{
  options_.adjustment.localization_sigma_m = options.localization_sigma_m;
  options_.adjustment.localization_sigma_deg = options.localization_sigma_deg;
  for (const auto& config : cameras)
    cameras_.emplace(config.name, std::make_unique<FixedCamera>(config, options.cameras));
}

Expected<bool> Survey::addRgbdFrame(const RgbdFrame& frame)
{
  ++stats_.frames;
  if (const Status valid = validateFrame(frame); !valid)
  {
    ++stats_.skipped;
    return valid.error();
  }
  if (!keyframes_.accept(frame.T_map_camera, frame.stamp))
    return false;
  const auto lines = extractor_.extract(frame);
  if (!lines)
  {
    ++stats_.skipped;
    return lines.error();
  }
  map_.insert(*lines);
  keyframe_data_.push_back(toKeyframe(frame, *lines));
  adjusted_ = false;
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

const LineMap& Survey::lineMap() const
{
  if (!adjusting(options_) || keyframe_data_.empty())
    return map_;
  if (!adjusted_)
    adjustMap();
  return adjusted_map_;
}

void Survey::adjustMap() const
{
  const double start = threadCpuMs();
  std::vector<PoseCorrection> corrections(keyframe_data_.size());
  LineMap current = map_;
  size_t used = 0, dropped = 0;
  for (int round = 0; round < options_.adjustment_rounds; ++round)
  {
    std::vector<MapLine> lines;
    for (const auto& line : current.lines(options_.min_map_support))
      if (line.spread() <= options_.max_map_spread_m)
        lines.push_back(line);
    std::vector<AdjustedLine> starts;
    for (const auto& line : lines)
      starts.push_back({line.point, line.direction});
    const auto observations = associateObservations(keyframe_data_, corrections, lines, options_.map);
    const auto result = adjustLineMap(keyframe_data_, starts, observations, corrections, options_.adjustment);
    if (!result)
      break;  // nothing to adjust: the map stays as tf put it
    corrections = result->corrections;
    used = observations.size();
    dropped = result->dropped;
    current = rebuildLineMap(keyframe_data_, corrections, options_.map);
  }
  adjusted_map_ = current;
  corrections_ = corrections;
  adjusted_ = true;
  double sum_m = 0.0, sum_rad = 0.0;
  for (const auto& c : corrections)
  {
    sum_m += c.x * c.x + c.y * c.y;
    sum_rad += c.yaw * c.yaw;
  }
  const double n = std::max<size_t>(1, corrections.size());
  stats_.adjusted_observations = used;
  stats_.dropped_observations = dropped;
  stats_.mean_correction_m = std::sqrt(sum_m / n);
  stats_.mean_correction_deg = std::sqrt(sum_rad / n) * 180.0 / M_PI;
  stats_.adjustment_cpu_ms = cpuMsSince(start);
}

std::vector<PoseCorrection> Survey::poseCorrections() const
{
  lineMap();
  return adjusted_ ? corrections_ : std::vector<PoseCorrection>(keyframe_data_.size());
}

MapPlacementUncertainty Survey::mapPlacement() const
{
  MapPlacementUncertainty out;
  if (keyframe_data_.empty())
    return out;
  for (const auto& kf : keyframe_data_)
    out.centre += kf.T_map_camera.translation() / static_cast<double>(keyframe_data_.size());
  if (!adjusting(options_))
    return out;
  // The mean of a stationary error with exponential correlation tau over a time T >> tau has the variance
  // sigma^2 * 2 tau / T; no fewer than one independent sample.
  const double span = keyframe_data_.back().stamp - keyframe_data_.front().stamp;
  const double factor = std::min(1.0, std::sqrt(2.0 * options_.localization_correlation_s / std::max(1e-9, span)));
  out.sigma_m = options_.localization_sigma_m * factor;
  out.sigma_deg = options_.localization_sigma_deg * factor;
  return out;
}

Expected<FixedCameraResult> Survey::calibrate(const std::string& name, const std::string& world_frame)
{
  if (!hasCamera(name))
    return Error(ErrorCode::kInvalidInput, "unknown camera '" + name + "'");
  auto result = camera(name).calibrate(mapSegments(), world_frame, mapLineSigmas());
  if (!result)
    return result;
  // The whole map may be off by the placement: a shift of the camera, and a turn about the survey's centre that
  // turns the camera and moves it by the turn times its horizontal distance from the centre.
  const MapPlacementUncertainty placement = mapPlacement();
  CameraUncertainty& u = result->calibration.uncertainty;
  if (u.available && (placement.sigma_m > 0.0 || placement.sigma_deg > 0.0))
  {
    const Eigen::Vector3d arm = result->calibration.camera.pose().center() - placement.centre;
    const double turn_m = placement.sigma_deg * M_PI / 180.0 * arm.head<2>().norm();
    u.position_m =
        std::sqrt(u.position_m * u.position_m + 2.0 * placement.sigma_m * placement.sigma_m + turn_m * turn_m);
    u.rotation_deg = std::hypot(u.rotation_deg, placement.sigma_deg);
    if (result->file.quality)
    {
      auto& extra = result->file.quality->extra;
      extra["sigma_position_m"] = u.position_m;
      extra["sigma_rotation_deg"] = u.rotation_deg;
      extra["sigma_map_placement_m"] = std::hypot(placement.sigma_m, placement.sigma_m);
      extra["sigma_map_placement_deg"] = placement.sigma_deg;
    }
    camera(name).setCalibration(result->file);
  }
  return result;
}

std::vector<MapLine> Survey::usedMapLines() const
{
  std::vector<MapLine> out;
  for (const auto& line : lineMap().lines(options_.min_map_support))
    if (line.spread() <= options_.max_map_spread_m)
      out.push_back(line);
  return out;
}

std::vector<double> Survey::mapLineSigmas() const
{
  std::vector<double> out;
  // The map line's standard error predicted from its observations (it falls with their number, where the spread
  // does not: a line seen 20 times counted as much as one seen twice), with the floor for the errors the
  // observations share (an edge's depth bias seen from similar viewpoints); the spread when nothing is predicted.
  for (const auto& line : usedMapLines())
    out.push_back(line.sigma() > 0.0 ? std::hypot(options_.min_map_line_sigma_m, line.sigma())
                                     : std::max(options_.min_map_line_sigma_m, line.spread()));
  return out;
}

std::vector<Segment3d> Survey::mapSegments() const
{
  std::vector<Segment3d> out;
  for (const auto& line : usedMapLines())
    out.push_back({line.a(), line.b()});
  return out;
}

std::vector<std::string> Survey::cameraNames() const
{
  std::vector<std::string> names;
  for (const auto& [name, camera] : cameras_)
    names.push_back(name);
  return names;
}

void Survey::reset()
{
  map_.clear();
  keyframes_.reset();
  keyframe_data_.clear();
  adjusted_map_.clear();
  corrections_.clear();
  adjusted_ = false;
  last_fixed_stamp_.clear();
  for (auto& [name, camera] : cameras_)
    camera->reset();
  stats_ = SurveyStats();
}

}  // namespace insitu_calibration
