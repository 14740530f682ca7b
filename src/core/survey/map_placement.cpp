#include "insitu_calibration/survey/map_placement.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace insitu_calibration
{
double MapPlacementUncertainty::atPoint(const Eigen::Vector3d& point) const
{
  const double turn_m = sigma_deg * M_PI / 180.0 * (point - centre).head<2>().norm();
  return std::sqrt(2.0 * sigma_m * sigma_m + turn_m * turn_m);
}

std::vector<int> recordingOf(const std::vector<Keyframe>& keyframes)
{
  std::vector<int> recording(keyframes.size(), 0);
  for (size_t k = 1; k < keyframes.size(); ++k)
  {
    const bool starts = keyframes[k].starts_recording || !(keyframes[k].stamp > keyframes[k - 1].stamp);
    recording[k] = recording[k - 1] + (starts ? 1 : 0);
  }
  return recording;
}

double meanErrorScale(const std::vector<double>& stamps, double correlation_s)
{
  if (stamps.empty())
    return 0.0;
  // sum_ij rho^|ti - tj| = n + 2 sum_j a_j, a_j = sum_{i<j} rho_ij = rho_{j-1,j} (a_{j-1} + 1) for ascending stamps.
  const double tau = std::max(correlation_s, 0.0);
  double sum = 1.0, a = 0.0;
  for (size_t j = 1; j < stamps.size(); ++j)
  {
    const double dt = std::abs(stamps[j] - stamps[j - 1]);
    a = tau > 0.0 ? std::exp(-dt / tau) * (a + 1.0) : 0.0;
    sum += 1.0 + 2.0 * a;
  }
  return std::sqrt(sum) / static_cast<double>(stamps.size());
}

MapPlacementUncertainty placementOverKeyframes(const std::vector<Keyframe>& keyframes,
                                               const std::vector<size_t>& selected, const LocaliserErrorModel& model)
{
  MapPlacementUncertainty out;
  const std::vector<int> recording = recordingOf(keyframes);
  std::vector<std::pair<int, double>> samples;  // (recording, stamp)
  for (size_t k : selected)
    if (k < keyframes.size())
    {
      out.centre += keyframes[k].T_map_camera.translation();
      samples.push_back({recording[k], keyframes[k].stamp});
    }
  out.keyframes = samples.size();
  if (samples.empty())
    return out;
  out.centre /= static_cast<double>(samples.size());
  std::stable_sort(samples.begin(), samples.end());
  double scale = 0.0;
  for (size_t begin = 0; begin < samples.size();)
  {
    size_t end = begin;
    std::vector<double> stamps;
    for (; end < samples.size() && samples[end].first == samples[begin].first; ++end)
      stamps.push_back(samples[end].second);
    scale += meanErrorScale(stamps, model.correlation_s) * static_cast<double>(stamps.size()) / samples.size();
    begin = end;
  }
  out.sigma_m = model.sigma_m * scale;
  out.sigma_deg = model.sigma_deg * scale;
  return out;
}

std::vector<size_t> keyframesObserving(const std::vector<Keyframe>& keyframes, const std::vector<const MapLine*>& lines)
{
  std::vector<std::pair<double, size_t>> by_stamp;
  for (size_t k = 0; k < keyframes.size(); ++k)
    by_stamp.push_back({keyframes[k].stamp, k});
  std::sort(by_stamp.begin(), by_stamp.end());
  std::vector<bool> seen(keyframes.size(), false);
  // Two recordings may carry the same stamps (simulated ones start alike): a stamp marks every keyframe that has it.
  const auto mark = [&](double from, double to) {
    auto it = std::lower_bound(by_stamp.begin(), by_stamp.end(), std::make_pair(from - 1e-6, size_t{0}));
    for (; it != by_stamp.end() && it->first <= to + 1e-6; ++it)
      seen[it->second] = true;
  };
  for (const MapLine* line : lines)
  {
    if (!line)
      continue;
    for (const MapObservation& o : line->observations)
      mark(o.stamp, o.stamp);
    if (line->observations.empty() && line->first_stamp <= line->last_stamp)
      mark(line->first_stamp, line->last_stamp);
  }
  std::vector<size_t> out;
  for (size_t k = 0; k < seen.size(); ++k)
    if (seen[k])
      out.push_back(k);
  return out;
}
}  // namespace insitu_calibration
