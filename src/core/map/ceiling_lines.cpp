#include "insitu_calibration/map/ceiling_lines.h"

#include <algorithm>
#include <cmath>

namespace insitu_calibration
{
FloorLineOptions CeilingLineOptions::defaultLineOptions()
{
  FloorLineOptions o;
  o.enabled = true;
  o.height_sigma_m = 0.002;  // the plane's height beyond its measured error (the depth's bias at edges)
  return o;
}

std::optional<PlaneHeight> measureCeilingHeight(const std::vector<Keyframe>& keyframes,
                                                const CeilingLineOptions& options, double floor_height_m)
{
  std::vector<double> heights;
  const double max_slope = std::sin(options.max_tilt_deg * M_PI / 180.0);
  for (const auto& kf : keyframes)
    for (const auto& l : kf.lines)
    {
      const Eigen::Vector3d a = kf.T_map_camera * l.line.a, b = kf.T_map_camera * l.line.b;
      const double z = 0.5 * (a.z() + b.z());
      if (std::abs((b - a).normalized().z()) <= max_slope &&
          z >= kf.T_map_camera.translation().z() + options.min_clearance_m &&
          z >= floor_height_m + options.min_height_m)
        heights.push_back(z);
    }
  std::sort(heights.begin(), heights.end());
  // The densest window of plane_tolerance_m (the highest of equals: the ceiling above a shelf's top).
  size_t best_begin = 0, best_count = 0;
  for (size_t i = 0, j = 0; i < heights.size(); ++i)
  {
    while (heights[i] - heights[j] > options.plane_tolerance_m)
      ++j;
    if (i - j + 1 >= best_count)
    {
      best_count = i - j + 1;
      best_begin = j;
    }
  }
  if (static_cast<int>(best_count) < std::max(3, options.min_plane_lines))
    return std::nullopt;
  std::vector<double> members(heights.begin() + static_cast<long>(best_begin),
                              heights.begin() + static_cast<long>(best_begin + best_count));
  PlaneHeight plane;
  plane.lines = static_cast<int>(members.size());
  plane.height_m = members[members.size() / 2];
  double sum_squares = 0.0;
  for (const double h : members)
    sum_squares += (h - plane.height_m) * (h - plane.height_m);
  // The median's standard error: 1.25 sigma / sqrt(n).
  plane.sigma_m = 1.25 * std::sqrt(sum_squares / members.size()) / std::sqrt(static_cast<double>(members.size()));
  return plane;
}

namespace
{
// Whether an observation's depth (if any) puts it on the plane.
bool onPlane(const CeilingObservation& obs, double height_m, const CeilingLineOptions& o)
{
  return !obs.has_depth || std::abs(obs.depth_height_m - height_m) <=
                               o.depth_tolerance_m + o.depth_tolerance_per_m2 * obs.range_m * obs.range_m;
}
}  // namespace

std::vector<MapLine> confirmCeilingLines(const std::vector<Keyframe>& keyframes,
                                         const std::vector<PoseCorrection>& corrections,
                                         const std::vector<MapLine>& depth_lines, const CeilingLineOptions& options,
                                         double floor_height_m)
{
  if (!options.enabled)
    return {};
  const auto plane = measureCeilingHeight(keyframes, options, floor_height_m);
  if (!plane)
    return {};
  // The floor lines' machinery on the plane: keyframes reduced to their pose and their observations on it.
  std::vector<Keyframe> on_plane(keyframes.size());
  for (size_t k = 0; k < keyframes.size(); ++k)
  {
    on_plane[k].stamp = keyframes[k].stamp;
    on_plane[k].T_map_camera = keyframes[k].T_map_camera;
    on_plane[k].focal_px = keyframes[k].focal_px;
    for (const auto& obs : keyframes[k].ceiling)
      if (onPlane(obs, plane->height_m, options))
        on_plane[k].floor.push_back(obs.image);
  }
  FloorLineOptions lines = options.lines;
  lines.enabled = true;
  lines.floor_height_m = plane->height_m;
  lines.height_sigma_m = std::hypot(options.lines.height_sigma_m, plane->sigma_m);
  std::vector<MapLine> out = confirmFloorLines(on_plane, corrections, depth_lines, lines);
  for (auto& line : out)
    line.source = MapLineSource::kCeiling;
  return out;
}

}  // namespace insitu_calibration
