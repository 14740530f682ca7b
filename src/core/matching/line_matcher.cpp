// The matcher's entry points and its outer loop: the steps live beside it (line_projection: image and projected
// lines; match_scores: the search and explanation scores; prior_search: step 1; line_association: step 2;
// match_refinement: step 3 from one start; local_moves: basin hopping and the influence check).
#include "insitu_calibration/matching/line_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "insitu_calibration/matching/direction_lines.h"
#include "matching/local_moves.h"
#include "matching/match_refinement.h"
#include "matching/matcher_trace.h"
#include "matching/prior_search.h"

namespace insitu_calibration
{
namespace matching
{
std::string describeCamera(const CameraModel& camera)
{
  const Eigen::Vector3d c = camera.pose().center();
  const Eigen::Vector3d f = camera.pose().rotation.row(2).transpose();
  char buffer[200];
  std::snprintf(buffer, sizeof(buffer), "fx %.1f, centre %.3f %.3f %.3f, axis %.3f %.3f %.3f", camera.intrinsics().fx,
                c.x(), c.y(), c.z(), f.x(), f.y(), f.z());
  return buffer;
}

namespace
{
Status checkMatchInputs(const std::vector<Segment3d>& map_lines,
                        const std::vector<std::vector<Eigen::Vector2d>>& image_lines, int image_width, int image_height)
{
  if (map_lines.empty())
    return Error(ErrorCode::kNotEnoughData, "the line map is empty: survey the area the camera sees first");
  if (image_lines.empty())
    return Error(ErrorCode::kNotEnoughData, "no lines were found in the camera's image");
  if (image_width <= 0 || image_height <= 0)
    return Error(ErrorCode::kInvalidInput, "the image size is not positive");
  return Success{};
}

// Each start refined (match, calibrate, re-match), best explanation first.
Expected<std::vector<Incumbent>> refinedStarts(const MatchingProblem& problem, const std::vector<CameraModel>& starts,
                                               double initial_max_distance_px)
{
  std::vector<Incumbent> refined;
  std::string last_error = "no start camera";
  for (const CameraModel& start : starts)
  {
    trace(problem.options, "start %s", describeCamera(start).c_str());
    auto candidate = refineMatches(problem, start, initial_max_distance_px, {});
    if (!candidate)
    {
      last_error = candidate.error().message();
      continue;
    }
    const double score = rankingScore(candidate->calibration.camera, problem);
    traceResult(problem.options, "start", *candidate, score);
    refined.push_back(Incumbent{std::move(*candidate), score, {}});
  }
  if (refined.empty())
    return Error(ErrorCode::kNoSolution, "no start of the prior search led to a calibration: " + last_error);
  std::stable_sort(refined.begin(), refined.end(),
                   [](const Incumbent& a, const Incumbent& b) { return a.score < b.score; });
  return refined;
}

// Whether two cameras are one for the local moves (the options' same_camera_* tolerances, far below the hops).
bool sameCamera(const CameraModel& a, const CameraModel& b, const LineMatcherOptions& options)
{
  const double angle = Eigen::AngleAxisd(a.pose().rotation * b.pose().rotation.transpose()).angle();
  return (a.pose().center() - b.pose().center()).norm() <= options.same_camera_m &&
         angle <= options.same_camera_deg * M_PI / 180.0 &&
         std::abs(a.intrinsics().fx / b.intrinsics().fx - 1.0) <= options.same_camera_relative;
}

// The local moves (local_moves.h) alternated while either explains the image better, at most max_local_rounds times.
// They stop once the incumbent is a camera at which the local moves of an earlier start ended with no move improving
// it (`reached`): going on would retrace that start's path to the same result. True when they ended so.
bool improveLocally(const MatchingProblem& problem, bool hop, const std::vector<CameraModel>& reached,
                    Incumbent* incumbent)
{
  for (int round = 0; round < problem.options.max_local_rounds; ++round)
  {
    const CameraModel& camera = incumbent->result.calibration.camera;
    if (std::any_of(reached.begin(), reached.end(),
                    [&](const CameraModel& r) { return sameCamera(camera, r, problem.options); }))
    {
      trace(problem.options, "the local moves of an earlier start ended at this camera");
      return false;
    }
    const bool hopped = hop && problem.options.basin_hopping && hopRound(problem, incumbent);
    const bool pruned = influenceRound(problem, incumbent);
    if (!hopped && !pruned)
      return true;
  }
  return false;
}

// The unmatched image lines under `camera`: images of edges of known directions (the vertical, the building's main
// horizontal ones along the matched map lines) as direction lines, the other long ones as plumb lines.
void addUnmatchedLines(const MatchingProblem& problem, const LineMatchResult& result, const CameraModel& camera,
                       CorrespondenceSet* set)
{
  const LineMatcherOptions& options = problem.options;
  std::vector<Segment3d> matched_map_lines;
  for (const auto& m : result.candidate_matches)
    matched_map_lines.push_back(problem.map_lines[m.map_line]);
  const std::vector<DirectionLine> directions =
      knownDirectionsOf(matched_map_lines, options.horizontal_direction_lines, options.min_direction_support);
  std::vector<bool> taken;
  set->direction_lines =
      directionLinesOf(result.candidate_matches, problem.image_lines, camera, directions, options.min_direction_line_px,
                       options.calibration.refinement.max_direction_line_px, &taken);
  set->straight_lines =
      straightLinesOf(result.candidate_matches, problem.image_lines, options.min_straight_line_px, taken);
  for (const auto& l : set->direction_lines)
    trace(options, "direction line %.1f %.1f -> %.1f %.1f (%zu points), direction %.4f %.4f %.4f (group %d)",
          l.image.front().x(), l.image.front().y(), l.image.back().x(), l.image.back().y(), l.image.size(),
          l.direction.x(), l.direction.y(), l.direction.z(), l.azimuth_group);
}

// The chosen result calibrated once more, with its priors weighed by the fit (the search's were stiffer) and the
// unmatched image lines as direction and plumb lines (only here: each adds parameters, too many for the exploration;
// none when min_direction_line_px, min_straight_line_px are 0).
void calibrateFinally(const MatchingProblem& problem, LineMatchResult* best)
{
  const LineMatcherOptions& options = problem.options;
  CorrespondenceSet set = best->correspondences;
  addUnmatchedLines(problem, *best, best->calibration.camera, &set);
  if (problem.final_map_sigmas &&
      problem.final_map_sigmas->size() == problem.map_lines.size())  // k-th line: k-th match
    for (size_t k = 0; k < set.lines.size() && k < best->candidate_matches.size(); ++k)
      set.lines[k].world_sigma_m = worldSigmaOf(best->candidate_matches[k], problem, *problem.final_map_sigmas);
  auto polished = calibrateCamera(set, options.calibration, best->calibration.camera);
  if (!polished)
    return;
  trace(options, "with %zu plumb lines and %zu direction lines: %zu -> %zu inlier lines, lambda %.4g -> %.4g, %s",
        set.straight_lines.size(), set.direction_lines.size(), best->calibration.inlier_count, polished->inlier_count,
        best->calibration.camera.distortion().lambda, polished->camera.distortion().lambda,
        describeCamera(polished->camera).c_str());
  best->calibration = *polished;
  best->correspondences = set;
  best->matches.clear();
  for (size_t k = 0; k < best->candidate_matches.size(); ++k)
    if (k < polished->inlier_lines.size() && polished->inlier_lines[k])
      best->matches.push_back(best->candidate_matches[k]);
}

// The local moves from each of the local_search_starts best starts (a wrong local optimum found from one start is
// often beaten by the moves from another), the result that explains the image best, then the plumb lines.
Expected<LineMatchResult> matchFromStarts(const MatchingProblem& problem, const std::vector<CameraModel>& starts,
                                          double initial_max_distance_px, bool hop)
{
  Expected<std::vector<Incumbent>> refined = refinedStarts(problem, starts, initial_max_distance_px);
  if (!refined)
    return refined.error();
  std::vector<CameraModel> cameras;
  for (const Incumbent& start : *refined)
    cameras.push_back(start.result.calibration.camera);
  const std::vector<size_t> explored = distinctStarts(cameras, problem.options);
  size_t best = explored.front();
  std::vector<CameraModel> reached;  // where the local moves of the starts before ended, no move improving it
  for (const size_t k : explored)
  {
    trace(problem.options, "local moves from start %zu (score %.3f)", k + 1, (*refined)[k].score);
    if (improveLocally(problem, hop, reached, &(*refined)[k]))
      reached.push_back((*refined)[k].result.calibration.camera);
    trace(problem.options, "local moves from start %zu: score %.3f", k + 1, (*refined)[k].score);
    if ((*refined)[k].score < (*refined)[best].score)
      best = k;
  }
  trace(problem.options, "chosen: start %zu of %zu refined, %zu explored", best + 1, refined->size(), explored.size());
  LineMatchResult result = std::move((*refined)[best].result);
  calibrateFinally(problem, &result);
  return result;
}
}  // namespace
}  // namespace matching

std::vector<size_t> distinctStarts(const std::vector<CameraModel>& cameras, const LineMatcherOptions& options)
{
  const size_t wanted = static_cast<size_t>(std::max(1, options.local_search_starts));
  std::vector<size_t> chosen;
  for (size_t k = 0; k < cameras.size() && chosen.size() < wanted; ++k)
    if (std::none_of(chosen.begin(), chosen.end(),
                     [&](size_t c) { return matching::sameCamera(cameras[k], cameras[c], options); }))
      chosen.push_back(k);
  return chosen;
}

LineMatcherOptions::LineMatcherOptions()
{
  calibration.robust_noise_level = true;
  calibration.refinement.vertex_outlier_sigmas = 5.0;
  calibration.refinement.single_focal = true;
  calibration.refinement.principal_point_prior_sigma = 0.03;
}

Expected<LineMatchResult> matchAndCalibrate(const std::vector<Segment3d>& map_lines,
                                            const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                            const CameraPrior& prior, int image_width, int image_height,
                                            const LineMatcherOptions& options,
                                            const std::vector<double>& map_line_sigmas_m,
                                            const std::vector<double>& image_line_world_sigmas_m,
                                            const std::vector<double>& final_map_line_sigmas_m)
{
  if (const Status valid = matching::checkMatchInputs(map_lines, image_lines, image_width, image_height); !valid)
    return valid.error();
  if (!prior.position.allFinite() || !prior.direction.allFinite() || !(prior.direction.norm() > 0.0) ||
      !(prior.horizontal_fov_deg > 0.0 && prior.horizontal_fov_deg < 180.0))
    return Error(ErrorCode::kInvalidInput,
                 "the camera prior needs a finite position, a non-zero direction and a "
                 "horizontal field of view between 0 and 180 degrees");
  matching::MatchingProblem problem(map_lines, map_line_sigmas_m, image_lines, image_width, image_height, options);
  problem.prior = &prior;
  problem.image_world_sigmas = &image_line_world_sigmas_m;
  problem.final_map_sigmas = &final_map_line_sigmas_m;
  return matching::matchFromStarts(problem, matching::searchPrior(problem, prior), options.initial_max_distance_px,
                                   true);
}

Expected<LineMatchResult> matchAndCalibrateFrom(const std::vector<Segment3d>& map_lines,
                                                const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                                const CameraModel& start, int image_width, int image_height,
                                                const LineMatcherOptions& options,
                                                const std::vector<double>& map_line_sigmas_m,
                                                const std::vector<double>& image_line_world_sigmas_m,
                                                const std::vector<double>& final_map_line_sigmas_m)
{
  if (const Status valid = matching::checkMatchInputs(map_lines, image_lines, image_width, image_height); !valid)
    return valid.error();
  matching::MatchingProblem problem(map_lines, map_line_sigmas_m, image_lines, image_width, image_height, options);
  problem.image_world_sigmas = &image_line_world_sigmas_m;
  problem.final_map_sigmas = &final_map_line_sigmas_m;
  return matching::matchFromStarts(problem, {start}, options.known_camera_max_distance_px, false);
}

bool beyondPriorDistance(const Eigen::Vector3d& centre, const CameraPrior& prior, double max_sigmas)
{
  return max_sigmas > 0.0 && (centre - prior.position).norm() > max_sigmas * prior.position_sigma_m;
}

double explanationScore(const std::vector<Segment3d>& map_lines,
                        const std::vector<std::vector<Eigen::Vector2d>>& image_lines, const CameraModel& camera,
                        int image_width, int image_height, const LineMatcherOptions& options)
{
  const std::vector<double> no_sigmas;
  const matching::MatchingProblem problem(map_lines, no_sigmas, image_lines, image_width, image_height, options);
  return matching::explanationScore(camera, problem);
}
}  // namespace insitu_calibration
