#include "insitu_calibration/solvers/ransac.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

#include "insitu_calibration/io/parameter_range.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/solvers/decomposition.h"

namespace insitu_calibration
{
namespace
{
struct Hypothesis
{
  CameraModel camera;
  double score = std::numeric_limits<double>::infinity();  // MSAC: sum of min(e^2, t^2)
  std::vector<bool> inliers;
  size_t inlier_count = 0;
};

CorrespondenceSet subset(const CorrespondenceSet& data, const std::vector<size_t>& lines)
{
  CorrespondenceSet s;
  s.image_width = data.image_width;
  s.image_height = data.image_height;
  s.points = data.points;
  for (size_t i : lines)
    s.lines.push_back(data.lines[i]);
  return s;
}

std::optional<CameraModel> fitCamera(const CorrespondenceSet& data, const DltOptions& dlt,
                                     const Eigen::Vector2d& center)
{
  const auto linear = solveDltLinear(data, dlt, center);
  if (!linear)
    return std::nullopt;
  std::vector<Eigen::Vector3d> world;
  for (const auto& line : data.lines)
    world.insert(world.end(), line.world.begin(), line.world.end());
  const auto decomposed = decomposeProjection(linear->projection, world);
  if (!decomposed)
    return std::nullopt;
  return CameraModel(decomposed->intrinsics,
                     DivisionModel{dlt.estimate_distortion ? linear->lambda : 0.0,
                                   dlt.estimate_distortion ? center : decomposed->intrinsics.principalPoint()},
                     decomposed->pose);
}

Hypothesis score(const CorrespondenceSet& data, const CameraModel& camera, double threshold)
{
  LineConsensus c = scoreLines(camera, data, threshold);
  return Hypothesis{camera, c.score, std::move(c.inliers), c.inlier_count};
}
}  // namespace

double lineError(const CameraModel& camera, const LineCorrespondence& line)
{
  double sum = 0.0;
  for (double r : lineResiduals(camera, line))
  {
    if (!std::isfinite(r))
      return std::numeric_limits<double>::infinity();
    sum += r * r;
  }
  return line.world.empty() ? 0.0 : std::sqrt(sum / line.world.size());
}

size_t minimalLineCount(const DltOptions& dlt)
{
  return dlt.estimate_distortion ? 7 : 6;
}

LineConsensus scoreLines(const CameraModel& camera, const CorrespondenceSet& data, double threshold)
{
  LineConsensus c;
  c.inliers.assign(data.lines.size(), false);
  const double t2 = threshold * threshold;
  for (size_t i = 0; i < data.lines.size(); ++i)
  {
    const double e = lineError(camera, data.lines[i]);
    const double e2 = std::isfinite(e) ? e * e : t2;
    c.score += std::min(e2, t2);
    if (e2 < t2)
    {
      c.inliers[i] = true;
      ++c.inlier_count;
    }
  }
  return c;
}

Expected<RansacResult> ransacDlt(const CorrespondenceSet& data, const DltOptions& dlt, const RansacOptions& options)
{
  const size_t minimal = minimalLineCount(dlt);
  // Lines that can be sampled: with two world points they give their two equations.
  std::vector<size_t> candidates;
  for (size_t i = 0; i < data.lines.size(); ++i)
    if (data.lines[i].world.size() >= 2 && data.lines[i].partCount() >= 1)
      candidates.push_back(i);
  if (candidates.size() < minimal)
    return Error(ErrorCode::kNotEnoughData, "RANSAC needs at least " + std::to_string(minimal) +
                                                " lines with two or more world points, got " +
                                                std::to_string(candidates.size()));
  const Eigen::Vector2d center = dlt.distortion_center.value_or(data.imageCenter());
  std::mt19937 rng(options.seed);

  Hypothesis best;
  int iterations = 0;
  double needed = options.max_iterations;
  for (; iterations < options.max_iterations && iterations < needed; ++iterations)
  {
    std::vector<size_t> sample = candidates;
    // Partial Fisher-Yates: the first `minimal` entries become a uniform random sample.
    for (size_t k = 0; k < minimal; ++k)
      std::swap(sample[k], sample[k + std::uniform_int_distribution<size_t>(0, sample.size() - k - 1)(rng)]);
    sample.resize(minimal);
    if (dlt.estimate_distortion && data.points.empty() &&
        std::none_of(sample.begin(), sample.end(), [&](size_t i) { return data.lines[i].image.size() >= 3; }))
      continue;  // no curved line in the sample: lambda is not identifiable from it
    const auto camera = fitCamera(subset(data, sample), dlt, center);
    if (!camera)
      continue;
    Hypothesis h = score(data, *camera, options.inlier_threshold_px);
    if (h.score >= best.score)
      continue;
    if (options.local_optimization && h.inlier_count > minimal)
    {
      // LO step: re-fit on every inlier, keep it when it scores better.
      std::vector<size_t> inliers;
      for (size_t i = 0; i < h.inliers.size(); ++i)
        if (h.inliers[i])
          inliers.push_back(i);
      if (const auto refit = fitCamera(subset(data, inliers), dlt, center))
      {
        Hypothesis lo = score(data, *refit, options.inlier_threshold_px);
        if (lo.score < h.score)
          h = std::move(lo);
      }
    }
    best = std::move(h);
    // Adaptive stop: iterations for `confidence` of drawing one all-inlier sample.
    const double w = static_cast<double>(best.inlier_count) / data.lines.size();
    const double all_inliers = std::pow(w, static_cast<double>(minimal));
    needed = all_inliers >= 1.0   ? 0.0
             : all_inliers <= 0.0 ? options.max_iterations
                                  : std::log(1.0 - options.confidence) / std::log(1.0 - all_inliers);
  }
  if (best.inlier_count < minimal)
    return Error(ErrorCode::kNoSolution,
                 "RANSAC found no camera that fits " + std::to_string(minimal) + " or more lines within " +
                     formatParameterValue(options.inlier_threshold_px) + " px after " + std::to_string(iterations) +
                     " iterations; the correspondences are mostly wrong or the threshold "
                     "is too tight for the noise");
  RansacResult result;
  result.inliers = best.inliers;
  result.inlier_count = best.inlier_count;
  result.iterations = iterations;
  result.camera = best.camera;
  return result;
}

}  // namespace insitu_calibration
