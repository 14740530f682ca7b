#include "matching/prior_search.h"

#include "matching/hypotheses.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

namespace insitu_calibration
{
namespace matching
{
namespace
{
// A camera of the search: the prior turned, rolled, zoomed and moved.
struct SearchState
{
  double yaw = 0.0;
  double pitch = 0.0;
  double roll = 0.0;
  double fov_scale = 1.0;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
};

CameraModel cameraOf(const CameraPrior& prior, int width, int height, const SearchState& s)
{
  CameraPrior p = prior;
  p.position += s.offset;
  p.roll_deg += s.roll;
  return cameraFromPrior(p, width, height, s.yaw, s.pitch, s.fov_scale);
}

// The grid's spacing and the coarse scores' tolerances.
struct SearchGrid
{
  SearchGrid(const MatchingProblem& problem, const CameraPrior& prior)
      : angle_range(1.5 * prior.direction_sigma_deg),
        fov_range(1.5 * prior.fov_sigma_relative),
        n(std::max(1, problem.options.search_steps)),
        angle_step(n > 1 ? 2.0 * angle_range / (n - 1) : 0.0),
        fov_step(n > 1 ? 2.0 * fov_range / (n - 1) : 0.0),
        coarse_angle(std::max(5.0, 1.5 * angle_step))  // the angle tolerance covers what the grid spacing leaves
        ,
        cap(0.08 * std::hypot(problem.width, problem.height))
  {}
  double angle_range, fov_range;
  int n;
  double angle_step, fov_step, coarse_angle, cap;
};

// The best distinct cells of the grid (at least 1.5 steps apart in some value).
std::vector<SearchState> bestGridCells(const MatchingProblem& problem, const CameraPrior& prior, const SearchGrid& g)
{
  std::vector<std::pair<double, SearchState>> grid;
  for (int i = 0; i < g.n; ++i)
    for (int j = 0; j < g.n; ++j)
      for (int k = 0; k < g.n; ++k)
      {
        SearchState s;
        s.yaw = -g.angle_range + i * g.angle_step;
        s.pitch = -g.angle_range + j * g.angle_step;
        s.fov_scale = 1.0 - g.fov_range + k * g.fov_step;
        const double score =
            searchScore(cameraOf(prior, problem.width, problem.height, s), problem, g.coarse_angle, g.cap);
        grid.emplace_back(score, s);
      }
  std::sort(grid.begin(), grid.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<SearchState> seeds;
  for (const auto& scored : grid)
  {
    const SearchState& s = scored.second;  // not a structured binding: a lambda cannot capture one (clang)
    const bool distinct = std::all_of(seeds.begin(), seeds.end(), [&](const SearchState& t) {
      return std::abs(s.yaw - t.yaw) > 1.5 * g.angle_step || std::abs(s.pitch - t.pitch) > 1.5 * g.angle_step ||
             std::abs(s.fov_scale - t.fov_scale) > 1.5 * g.fov_step;
    });
    if (distinct)
      seeds.push_back(s);
    if (static_cast<int>(seeds.size()) >= std::max(1, problem.options.search_starts))
      break;
  }
  return seeds;
}

SearchState moved(SearchState s, int value, double d)
{
  switch (value)
  {
    case 0:
      s.yaw += d;
      break;
    case 1:
      s.pitch += d;
      break;
    case 2:
      s.roll += d;
      break;
    case 3:
      s.fov_scale += d;
      break;
    default:
      s.offset(value - 4) += d;
  }
  return s;
}

// Pattern search from a grid cell: try +-step on each value, keep improvements, halve the steps when none helps; the
// score's cap shrinks each round so that the last rounds count precisely explained lines.
CameraModel patternSearch(const MatchingProblem& problem, const CameraPrior& prior, const SearchGrid& g,
                          SearchState best)
{
  const LineMatcherOptions& o = problem.options;
  double steps_now[7] = {
      g.angle_step / 2,           g.angle_step / 2,           g.angle_step / 2,          g.fov_step / 2,
      prior.position_sigma_m / 2, prior.position_sigma_m / 2, prior.position_sigma_m / 2};
  double tolerance = g.coarse_angle;
  double round_cap = g.cap;
  const auto score = [&](const SearchState& s) {
    return searchScore(cameraOf(prior, problem.width, problem.height, s), problem, tolerance, round_cap);
  };
  for (int round = 0; round < 6; ++round)
  {
    tolerance = std::max(3.0, tolerance * 0.75);
    round_cap = std::max(o.search_min_cap_px, round_cap * o.search_cap_shrink);
    double best_score = score(best);
    bool improved = true;
    for (int sweep = 0; sweep < 8 && improved; ++sweep)
    {
      improved = false;
      for (int v = 0; v < 7; ++v)
        for (double sign : {-1.0, 1.0})
        {
          const SearchState s = moved(best, v, sign * steps_now[v]);
          const double candidate = score(s);
          if (candidate < best_score - 1e-9)
          {
            best_score = candidate;
            best = s;
            improved = true;
          }
        }
    }
    for (double& step : steps_now)
      step *= 0.5;
  }
  return cameraOf(prior, problem.width, problem.height, best);
}
}  // namespace

std::vector<CameraModel> searchPrior(const MatchingProblem& problem, const CameraPrior& prior)
{
  const SearchGrid grid(problem, prior);
  std::vector<CameraModel> cameras;
  if (problem.options.prior_start)
    cameras.push_back(cameraOf(prior, problem.width, problem.height, SearchState{}));
  for (const SearchState& seed : bestGridCells(problem, prior, grid))
    cameras.push_back(patternSearch(problem, prior, grid, seed));
  // Starts from line correspondences anywhere in the prior's cone, each refined by the same pattern search about it.
  if (problem.options.hypothesis_starts > 0)
    for (const CameraModel& hypothesis : lineHypotheses(problem, prior))
      cameras.push_back(patternSearch(problem, priorAt(hypothesis, problem.width, prior), grid, SearchState{}));
  return cameras;
}
}  // namespace matching

CameraModel cameraFromPrior(const CameraPrior& prior, int image_width, int image_height, double yaw_deg,
                            double pitch_deg, double fov_scale)
{
  using matching::kDegToRad;
  Intrinsics in;
  const double hfov = std::clamp(prior.horizontal_fov_deg * fov_scale, 1.0, 179.0) * kDegToRad;
  in.fx = in.fy = 0.5 * image_width / std::tan(0.5 * hfov);
  in.cx = prior.principal_point ? prior.principal_point->x() : 0.5 * (image_width - 1);
  in.cy = prior.principal_point ? prior.principal_point->y() : 0.5 * (image_height - 1);
  // Optical axis: the prior's direction turned by yaw about world z and pitched down/up about the camera's x axis.
  Eigen::Vector3d forward = prior.direction.normalized();
  forward = Eigen::AngleAxisd(yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()) * forward;
  Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ());
  if (right.norm() < 1e-6)  // looking straight up or down: any horizontal right vector
    right = Eigen::Vector3d::UnitX();
  right.normalize();
  forward = Eigen::AngleAxisd(-pitch_deg * kDegToRad, right) * forward;
  Eigen::Vector3d down = forward.cross(right).normalized();
  const Eigen::AngleAxisd roll(prior.roll_deg * kDegToRad, forward);
  right = roll * right;
  down = roll * down;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear().col(0) = right;
  world_from_camera.linear().col(1) = down;
  world_from_camera.linear().col(2) = forward;
  world_from_camera.translation() = prior.position;
  return CameraModel(in, DivisionModel{0.0, in.principalPoint()}, CameraPose::fromWorldFromCamera(world_from_camera));
}
}  // namespace insitu_calibration
