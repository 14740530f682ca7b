#include "matching/match_refinement.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include "matching/matcher_trace.h"

namespace insitu_calibration
{
namespace matching
{
std::vector<std::vector<Eigen::Vector2d>> straightLinesOf(const std::vector<LineMatch>& matches,
                                                          const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                                          double min_length_px, const std::vector<bool>& taken)
{
  std::vector<std::vector<Eigen::Vector2d>> out;
  if (!(min_length_px > 0.0))
    return out;
  const std::vector<bool> matched = matchedImageLines(matches, image_lines.size());
  for (size_t i = 0; i < image_lines.size(); ++i)
  {
    const auto& l = image_lines[i];
    if (!matched[i] && (taken.empty() || !taken[i]) && l.size() >= 3 && (l.back() - l.front()).norm() >= min_length_px)
      out.push_back(l);
  }
  return out;
}

double worldSigmaOf(const LineMatch& match, const MatchingProblem& problem, const std::vector<double>& map_sigmas)
{
  const double map = match.map_line < map_sigmas.size() ? map_sigmas[match.map_line] : 0.0;
  if (problem.image_world_sigmas && match.image_line < problem.image_world_sigmas->size())
    return std::hypot(map, (*problem.image_world_sigmas)[match.image_line]);
  return map;
}

namespace
{
// Each match's image line with world_points_per_line points along the visible part of its map line.
CorrespondenceSet correspondencesOf(const std::vector<LineMatch>& matches, const MatchingProblem& problem,
                                    const CameraModel& camera)
{
  CorrespondenceSet set;
  set.image_width = problem.width;
  set.image_height = problem.height;
  for (const auto& m : matches)
  {
    const Segment3d& s = problem.map_lines[m.map_line];
    const auto interval = visibleInterval(camera, s, problem.width, problem.height);
    const double t0 = interval ? interval->first : 0.0;
    const double t1 = interval ? interval->second : 1.0;
    LineCorrespondence line;
    line.image = problem.image_lines[m.image_line];
    line.world_sigma_m = worldSigmaOf(m, problem, problem.map_sigmas);
    const int n = std::max(2, problem.options.world_points_per_line);
    for (int k = 0; k < n; ++k)
      line.world.push_back(s.pointAt(t0 + (t1 - t0) * k / double(n - 1)));
    set.lines.push_back(std::move(line));
  }
  return set;
}

bool sameMatches(const std::vector<LineMatch>& a, const std::vector<LineMatch>& b)
{
  return !b.empty() && a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](auto& x, auto& y) {
    return x.image_line == y.image_line && x.map_line == y.map_line;
  });
}

// The last good round: its matches, their correspondences and calibration.
struct MatchRound
{
  std::vector<LineMatch> matches;
  CorrespondenceSet correspondences;
  std::optional<CameraCalibration> calibration;
};

LineMatchResult resultOf(const MatchRound& round, LineMatchResult result)
{
  result.calibration = *round.calibration;
  for (size_t k = 0; k < round.matches.size(); ++k)
    if (k < round.calibration->inlier_lines.size() && round.calibration->inlier_lines[k])
      result.matches.push_back(round.matches[k]);
  result.correspondences = round.correspondences;
  result.candidate_matches = round.matches;
  return result;
}
}  // namespace

Expected<LineMatchResult> refineMatches(const MatchingProblem& problem, const CameraModel& start,
                                        double initial_max_distance_px, const PairSet& banned, double abandon_above)
{
  const LineMatcherOptions& options = problem.options;
  LineMatchResult result;
  result.search_camera = start;
  CameraModel camera = start;
  double max_distance = initial_max_distance_px;
  double max_angle = options.max_angle_deg;
  MatchRound last;
  // The search's calibrations weigh the priors by the start's residuals: stiffer while a round's start is far, they
  // hold its weakly determined directions still (a narrow camera's focal length against its distance); the chosen
  // result's final calibration weighs them by its fit (calibrateFinally).
  CalibrationOptions calibration_options = options.calibration;
  calibration_options.refinement.priors_at_fit_noise = false;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration)
  {
    result.iterations = iteration + 1;
    std::vector<LineMatch> matches = matchLinesExcept(problem, camera, max_angle, max_distance, banned);
    if (sameMatches(matches, last.matches) && last.calibration)
    {
      result.converged = true;
      break;
    }
    CorrespondenceSet set = correspondencesOf(matches, problem, camera);
    auto calibration = calibrateCamera(set, calibration_options, camera);
    if (!calibration)
    {
      if (last.calibration)
        break;  // keep the last good calibration
      return Error(calibration.error().code(), "calibration on " + std::to_string(matches.size()) +
                                                   " matched lines failed: " + calibration.error().message());
    }
    trace(options, "  round %d: %zu matches (within %.1f px, %.1f deg), %zu inliers, RMS %.3f px, %s", iteration,
          matches.size(), max_distance, max_angle, calibration->inlier_count, calibration->reprojection.rms_px,
          describeCamera(calibration->camera).c_str());
    // A start that still explains the image worse than a known result after a few rounds is abandoned (the local
    // moves try many starts, most of them in vain).
    if (iteration + 1 >= options.abandon_after && rankingScore(calibration->camera, problem) > abandon_above)
      return Error(ErrorCode::kNoSolution, "abandoned: explains the image worse than the current result");
    last = {matches, set, *calibration};
    camera = calibration->camera;
    // The threshold shrinks towards what the residuals call for, at most halving per iteration: a start far from
    // the truth moves step by step, with the lines it already explains, instead of locking onto a wrong subset.
    const double target = std::max(options.min_distance_px, options.distance_factor * calibration->reprojection.rms_px);
    max_distance = std::max(target, options.distance_shrink * max_distance);
    max_angle = std::max(2.0, std::min(options.max_angle_deg, 10.0 * calibration->reprojection.rms_px / 20.0 + 2.0));
  }
  if (!last.calibration)
    return Error(ErrorCode::kNoSolution, "no calibration could be made from the matches");
  return resultOf(last, std::move(result));
}
}  // namespace matching
}  // namespace insitu_calibration
