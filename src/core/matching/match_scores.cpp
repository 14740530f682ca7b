#include <algorithm>

#include "matching/matching_problem.h"

namespace insitu_calibration
{
namespace matching
{
double searchScore(const CameraModel& camera, const MatchingProblem& problem, double max_angle_deg, double cap_px)
{
  std::vector<ProjectedLine> projected;
  projected.reserve(problem.map_lines.size());
  for (const auto& s : problem.map_lines)
  {
    ProjectedLine p = projectLine(camera, s, problem.width, problem.height, 2);
    if (p.visible)
      projected.push_back(std::move(p));
  }
  double score = 0.0;
  for (const auto& l : problem.image)
  {
    double best = cap_px;
    for (const auto& p : projected)
    {
      if (angleBetween(l.direction, p.direction) > max_angle_deg || overlap(l, p) < 0.3)
        continue;
      best = std::min(best, chordDistance(l, p));
    }
    score += best;
  }
  return score;
}

// The set of image lines is the same for every candidate camera, so the sums compare. The cap near the noise level
// makes it count the lines explained as precisely as the right camera explains them: a camera pulled off by a wrong
// match fits its matches worse and falls behind, however many lines it roughly explains.
double explanationScore(const CameraModel& camera, const MatchingProblem& problem)
{
  constexpr double kAngle = 3.0;
  const double cap_px = problem.options.explanation_cap_px;
  std::vector<ProjectedLine> projected;
  for (const auto& s : problem.map_lines)
  {
    ProjectedLine p = projectLine(camera, s, problem.width, problem.height, 16);
    if (p.visible)
      projected.push_back(std::move(p));
  }
  const double cap2 = cap_px * cap_px;
  double score = 0.0;
  for (const auto& l : problem.image)
  {
    if (l.points->size() < 2 || l.length < problem.options.min_image_length_px)
      continue;
    double best = cap2;
    for (const auto& p : projected)
      if (angleBetween(l.direction, p.direction) <= kAngle && overlap(l, p) >= 0.3 &&
          chordDistance(l, p) < 2.0 * cap_px + 2.0)
      {
        const double d = meanDistance(l, p);
        best = std::min(best, d * d);
      }
    score += best;
  }
  return score;
}

double rankingScore(const CameraModel& camera, const MatchingProblem& problem)
{
  const double score = explanationScore(camera, problem);
  const bool far = problem.prior && beyondPriorDistance(camera.pose().center(), *problem.prior,
                                                        problem.options.max_prior_distance_sigmas);
  return far ? score + kFarFromPriorPenalty : score;
}
}  // namespace matching
}  // namespace insitu_calibration
