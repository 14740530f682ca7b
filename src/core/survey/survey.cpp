#include "insitu_calibration/survey/survey.h"

#include <algorithm>
#include <cmath>

namespace insitu_calibration
{
Survey::Survey(const std::vector<FixedCameraConfig>& cameras, const SurveyOptions& options)
    : options_(options), extractor_(options.rgbd), map_(options.map), keyframes_(options.keyframes)
{
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

std::vector<MapLine> Survey::usedMapLines() const
{
  std::vector<MapLine> out;
  for (const auto& line : map_.lines(options_.min_map_support))
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
  last_fixed_stamp_.clear();
  for (auto& [name, camera] : cameras_)
    camera->reset();
  stats_ = SurveyStats();
}

}  // namespace insitu_calibration
