// Step 2 of the matcher: which image line is which map line under a given camera.
#include <algorithm>
#include <cmath>
#include <set>

#include "matching/matching_problem.h"

namespace insitu_calibration
{
namespace matching
{
namespace
{
// The largest distance of the shorter segment's end points from the longer one's line, m.
double separation(const Segment3d& s, const Segment3d& t)
{
  const Segment3d& longer = s.length() >= t.length() ? s : t;
  const Segment3d& shorter = s.length() >= t.length() ? t : s;
  const Eigen::Vector3d u = (longer.b - longer.a).normalized();
  auto off = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d d = p - longer.a;
    return (d - d.dot(u) * u).norm();
  };
  return std::max(off(shorter.a), off(shorter.b));
}

// Two map lines that project onto one image line are one edge mapped twice when they are also near in 3D.
bool sameEdge(const MatchingProblem& problem, size_t j, size_t k)
{
  const std::vector<double>& sigmas = problem.map_sigmas;
  const double sigma = sigmas.size() == problem.map_lines.size() ? std::hypot(sigmas[j], sigmas[k]) : 0.0;
  return separation(problem.map_lines[j], problem.map_lines[k]) <=
         std::max(problem.options.near_duplicate_m, 3.0 * sigma);
}

// An image line's compatible map lines (angle, overlap, distance), best first; empty when the best two fit about as
// well (repetitive texture: ceiling tiles, shelves), unless the second is within near_duplicate_px too and both are
// one edge in 3D (the same edge twice in the map).
std::vector<LineMatch> candidatesOf(size_t i, const MatchingProblem& problem,
                                    const std::vector<ProjectedLine>& projected, double max_angle_deg,
                                    double max_distance_px, const PairSet& banned)
{
  const LineMatcherOptions& options = problem.options;
  const ImageChord& chord = problem.image[i];
  std::vector<LineMatch> own;
  for (size_t j = 0; j < projected.size(); ++j)
  {
    const ProjectedLine& p = projected[j];
    if (!p.visible || angleBetween(chord.direction, p.direction) > max_angle_deg ||
        overlap(chord, p) < options.min_overlap)
      continue;
    if (chordDistance(chord, p) > 2.0 * max_distance_px)
      continue;
    const double d = meanDistance(chord, p);
    if (d <= max_distance_px && !banned.count({i, j}))
      own.push_back({i, j, d});
  }
  std::sort(own.begin(), own.end(),
            [](const LineMatch& a, const LineMatch& b) { return a.distance_px < b.distance_px; });
  if (own.size() >= 2)
  {
    const double best = own[0].distance_px;
    const double second = own[1].distance_px;
    const bool duplicate = second <= options.near_duplicate_px && sameEdge(problem, own[0].map_line, own[1].map_line);
    if (!duplicate && second - best < std::max(0.5 * best, options.min_separation_px))
      return {};
  }
  return own;
}
}  // namespace

// All compatible pairs, then greedy by distance so that each image line and each 3D line is used once.
std::vector<LineMatch> matchLinesExcept(const MatchingProblem& problem, const CameraModel& camera, double max_angle_deg,
                                        double max_distance_px, const PairSet& banned)
{
  std::vector<ProjectedLine> projected;
  for (const auto& s : problem.map_lines)
    projected.push_back(projectLine(camera, s, problem.width, problem.height, 16));
  std::vector<LineMatch> candidates;
  for (size_t i = 0; i < problem.image.size(); ++i)
  {
    if (problem.image[i].points->size() < 2 || problem.image[i].length < problem.options.min_image_length_px)
      continue;
    const std::vector<LineMatch> own = candidatesOf(i, problem, projected, max_angle_deg, max_distance_px, banned);
    candidates.insert(candidates.end(), own.begin(), own.end());
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const LineMatch& a, const LineMatch& b) { return a.distance_px < b.distance_px; });
  std::set<size_t> used_image;
  std::set<size_t> used_map;
  std::vector<LineMatch> matches;
  for (const auto& c : candidates)
  {
    if (used_image.count(c.image_line) || used_map.count(c.map_line))
      continue;
    used_image.insert(c.image_line);
    used_map.insert(c.map_line);
    matches.push_back(c);
  }
  std::sort(matches.begin(), matches.end(),
            [](const LineMatch& a, const LineMatch& b) { return a.image_line < b.image_line; });
  return matches;
}
}  // namespace matching

std::vector<bool> matchedImageLines(const std::vector<LineMatch>& matches, size_t image_line_count)
{
  std::vector<bool> matched(image_line_count, false);
  for (const auto& m : matches)
    if (m.image_line < image_line_count)
      matched[m.image_line] = true;
  return matched;
}

std::vector<LineMatch> matchLines(const std::vector<Segment3d>& map_lines,
                                  const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                  const CameraModel& camera, int image_width, int image_height, double max_angle_deg,
                                  double max_distance_px, const LineMatcherOptions& options)
{
  const std::vector<double> no_sigmas;
  const matching::MatchingProblem problem(map_lines, no_sigmas, image_lines, image_width, image_height, options);
  return matching::matchLinesExcept(problem, camera, max_angle_deg, max_distance_px, {});
}
}  // namespace insitu_calibration
