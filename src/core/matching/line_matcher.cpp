#include "insitu_calibration/matching/line_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <cstdio>
#include <functional>
#include <string>
#include <set>

#include <Eigen/Geometry>

#include "insitu_calibration/metrics.h"
#include "insitu_calibration/solvers/ransac.h"

namespace insitu_calibration
{
namespace
{
constexpr double kDegToRad = M_PI / 180.0;

// printf-style message to the options' trace, when there is one.
template <typename... Args>
void trace(const LineMatcherOptions& options, const char* format, Args... args)
{
  if (!options.trace)
    return;
  char buffer[512];
  std::snprintf(buffer, sizeof(buffer), format, args...);
  options.trace(buffer);
}

std::string describeCamera(const CameraModel& camera)
{
  const Eigen::Vector3d c = camera.pose().center();
  const Eigen::Vector3d f = camera.pose().rotation.row(2).transpose();
  char buffer[200];
  std::snprintf(buffer, sizeof(buffer), "fx %.1f, centre %.3f %.3f %.3f, axis %.3f %.3f %.3f", camera.intrinsics().fx,
                c.x(), c.y(), c.z(), f.x(), f.y(), f.z());
  return buffer;
}

bool inside(const Eigen::Vector2d& m, int width, int height)
{
  return m.x() >= 0.0 && m.y() >= 0.0 && m.x() <= width - 1.0 && m.y() <= height - 1.0;
}

// An image line summarised for matching: its points, chord direction and length.
struct ImageChord
{
  const std::vector<Eigen::Vector2d>* points;
  Eigen::Vector2d first;
  Eigen::Vector2d last;
  Eigen::Vector2d mid;
  Eigen::Vector2d direction;
  double length;
};

// A 3D line as the current camera sees it: the visible interval and its distorted projection.
struct ProjectedLine
{
  bool visible = false;
  double t0 = 0.0;
  double t1 = 1.0;
  std::vector<Eigen::Vector2d> polyline;
  Eigen::Vector2d first;
  Eigen::Vector2d last;
  Eigen::Vector2d direction;
  double length = 0.0;
};

std::vector<ImageChord> summarize(const std::vector<std::vector<Eigen::Vector2d>>& image_lines)
{
  std::vector<ImageChord> out;
  for (const auto& l : image_lines)
  {
    ImageChord s;
    s.points = &l;
    s.first = l.empty() ? Eigen::Vector2d::Zero() : l.front();
    s.last = l.empty() ? Eigen::Vector2d::Zero() : l.back();
    s.mid = 0.5 * (s.first + s.last);
    s.length = (s.last - s.first).norm();
    s.direction = s.length > 0.0 ? Eigen::Vector2d((s.last - s.first) / s.length) : Eigen::Vector2d::UnitX();
    out.push_back(s);
  }
  return out;
}

ProjectedLine project(const CameraModel& camera, const Segment3d& segment, int width, int height, int samples)
{
  ProjectedLine p;
  const auto interval = visibleInterval(camera, segment, width, height);
  if (!interval)
    return p;
  p.t0 = interval->first;
  p.t1 = interval->second;
  for (int k = 0; k < samples; ++k)
  {
    const double t = p.t0 + (p.t1 - p.t0) * k / double(samples - 1);
    if (const auto m = camera.project(segment.pointAt(t)))
      p.polyline.push_back(*m);
  }
  if (p.polyline.size() < 2)
    return p;
  p.first = p.polyline.front();
  p.last = p.polyline.back();
  p.length = (p.last - p.first).norm();
  if (!(p.length > 1.0))
    return p;
  p.direction = (p.last - p.first) / p.length;
  p.visible = true;
  return p;
}

// Angle between undirected directions, degrees.
double angleBetween(const Eigen::Vector2d& a, const Eigen::Vector2d& b)
{
  return std::acos(std::min(1.0, std::abs(a.dot(b)))) / kDegToRad;
}

// Fraction of the image line's chord covered by the projected line's chord (projected onto the image line).
double overlap(const ImageChord& image, const ProjectedLine& projected)
{
  if (!(image.length > 0.0))
    return 0.0;
  const double s0 = (projected.first - image.first).dot(image.direction);
  const double s1 = (projected.last - image.first).dot(image.direction);
  const double lo = std::max(0.0, std::min(s0, s1));
  const double hi = std::min(image.length, std::max(s0, s1));
  return std::max(0.0, hi - lo) / image.length;
}

// Mean distance of the image line's points to the projected polyline.
double meanDistance(const ImageChord& image, const ProjectedLine& projected)
{
  double sum = 0.0;
  for (const auto& m : *image.points)
    sum += distanceToPolyline(m, projected.polyline);
  return sum / image.points->size();
}

// Fast distance for the search: the image chord's end points and midpoint to the projected chord's line.
double chordDistance(const ImageChord& image, const ProjectedLine& projected)
{
  const Eigen::Vector2d normal(-projected.direction.y(), projected.direction.x());
  return (std::abs(normal.dot(image.first - projected.first)) + std::abs(normal.dot(image.mid - projected.first)) +
          std::abs(normal.dot(image.last - projected.first))) /
         3.0;
}

// How badly a camera explains the image lines: each line's distance to its nearest compatible projection, capped.
double searchScore(const CameraModel& camera, const std::vector<Segment3d>& map_lines,
                   const std::vector<ImageChord>& image, int width, int height, double max_angle_deg, double cap_px)
{
  std::vector<ProjectedLine> projected;
  projected.reserve(map_lines.size());
  for (const auto& s : map_lines)
  {
    ProjectedLine p = project(camera, s, width, height, 2);
    if (p.visible)
      projected.push_back(std::move(p));
  }
  double score = 0.0;
  for (const auto& l : image)
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

// A grid over yaw, pitch and field of view within 1.5 sigma; the `starts` best distinct cells are then each refined
// by a pattern search over all seven values (repetitive structure such as a row of windows gives several local
// optima, and the best grid cell is not always the right one).
std::vector<CameraModel> searchPrior(const std::vector<Segment3d>& map_lines, const std::vector<ImageChord>& image,
                                     const CameraPrior& prior, int width, int height, int steps, int starts,
                                     double min_cap_px, double cap_shrink)
{
  const double angle_range = 1.5 * prior.direction_sigma_deg;
  const double fov_range = 1.5 * prior.fov_sigma_relative;
  const int n = std::max(1, steps);
  const double angle_step = n > 1 ? 2.0 * angle_range / (n - 1) : 0.0;
  const double fov_step = n > 1 ? 2.0 * fov_range / (n - 1) : 0.0;
  // Coarse: the angle tolerance covers what the grid spacing leaves.
  const double coarse_angle = std::max(5.0, 1.5 * angle_step);
  const double cap = 0.08 * std::hypot(width, height);
  std::vector<std::pair<double, SearchState>> grid;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
      {
        SearchState s;
        s.yaw = -angle_range + i * angle_step;
        s.pitch = -angle_range + j * angle_step;
        s.fov_scale = 1.0 - fov_range + k * fov_step;
        const double score =
            searchScore(cameraOf(prior, width, height, s), map_lines, image, width, height, coarse_angle, cap);
        grid.emplace_back(score, s);
      }
  std::sort(grid.begin(), grid.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<SearchState> seeds;
  for (const auto& scored : grid)
  {
    const SearchState& s = scored.second;  // not a structured binding: clang 14 cannot capture those
    const bool distinct = std::all_of(seeds.begin(), seeds.end(), [&](const SearchState& t) {
      return std::abs(s.yaw - t.yaw) > 1.5 * angle_step || std::abs(s.pitch - t.pitch) > 1.5 * angle_step ||
             std::abs(s.fov_scale - t.fov_scale) > 1.5 * fov_step;
    });
    if (distinct)
      seeds.push_back(s);
    if (static_cast<int>(seeds.size()) >= std::max(1, starts))
      break;
  }
  std::vector<CameraModel> cameras;
  for (SearchState best : seeds)
  {
    double best_score = std::numeric_limits<double>::infinity();
    // Pattern search: try +-step on each value, keep improvements, halve the steps when none helps.
    double steps_now[7] = {angle_step / 2,
                           angle_step / 2,
                           angle_step / 2,
                           fov_step / 2,
                           prior.position_sigma_m / 2,
                           prior.position_sigma_m / 2,
                           prior.position_sigma_m / 2};
    double tolerance = coarse_angle;
    double round_cap = cap;
    for (int round = 0; round < 6; ++round)
    {
      tolerance = std::max(3.0, tolerance * 0.75);
      round_cap = std::max(min_cap_px, round_cap * cap_shrink);
      best_score =
          searchScore(cameraOf(prior, width, height, best), map_lines, image, width, height, tolerance, round_cap);
      bool improved = true;
      for (int sweep = 0; sweep < 8 && improved; ++sweep)
      {
        improved = false;
        for (int v = 0; v < 7; ++v)
          for (double sign : {-1.0, 1.0})
          {
            SearchState s = best;
            const double d = sign * steps_now[v];
            switch (v)
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
                s.offset(v - 4) += d;
            }
            const double score =
                searchScore(cameraOf(prior, width, height, s), map_lines, image, width, height, tolerance, round_cap);
            if (score < best_score - 1e-9)
            {
              best_score = score;
              best = s;
              improved = true;
            }
          }
      }
      for (double& step : steps_now)
        step *= 0.5;
    }
    cameras.push_back(cameraOf(prior, width, height, best));
  }
  return cameras;
}

// How well a camera explains the image lines: the sum over image lines of the squared mean distance to the nearest
// compatible projected 3D line (through the division model), capped at cap_px^2. Lower is better; the set of image
// lines is the same for every candidate camera, so the sums compare. The cap near the noise level makes it count
// the lines explained as precisely as the right camera explains them: a camera pulled off by a wrong match fits its
// matches worse and falls behind, however many lines it roughly explains.
double explanationScore(const CameraModel& camera, const std::vector<Segment3d>& map_lines,
                        const std::vector<ImageChord>& image, int width, int height, double min_length_px,
                        double cap_px)
{
  constexpr double kAngle = 3.0;
  std::vector<ProjectedLine> projected;
  for (const auto& s : map_lines)
  {
    ProjectedLine p = project(camera, s, width, height, 16);
    if (p.visible)
      projected.push_back(std::move(p));
  }
  const double cap2 = cap_px * cap_px;
  double score = 0.0;
  for (const auto& l : image)
  {
    if (l.points->size() < 2 || l.length < min_length_px)
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

// The image lines left unmatched are straight edges too (plumb lines for the distortion), when long enough (0: none).
std::vector<std::vector<Eigen::Vector2d>> straightLinesOf(const std::vector<LineMatch>& matches,
                                                          const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                                          double min_length_px)
{
  std::vector<std::vector<Eigen::Vector2d>> out;
  if (!(min_length_px > 0.0))
    return out;
  std::vector<bool> matched(image_lines.size(), false);
  for (const auto& m : matches)
    matched[m.image_line] = true;
  for (size_t i = 0; i < image_lines.size(); ++i)
  {
    const auto& l = image_lines[i];
    if (!matched[i] && l.size() >= 3 && (l.back() - l.front()).norm() >= min_length_px)
      out.push_back(l);
  }
  return out;
}

CorrespondenceSet correspondencesOf(const std::vector<LineMatch>& matches, const std::vector<Segment3d>& map_lines,
                                    const std::vector<double>& map_sigmas,
                                    const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                    const CameraModel& camera, int width, int height, int world_points,
                                    double min_straight_length_px)
{
  CorrespondenceSet set;
  set.image_width = width;
  set.image_height = height;
  for (const auto& m : matches)
  {
    const Segment3d& s = map_lines[m.map_line];
    const auto interval = visibleInterval(camera, s, width, height);
    const double t0 = interval ? interval->first : 0.0;
    const double t1 = interval ? interval->second : 1.0;
    LineCorrespondence line;
    line.image = image_lines[m.image_line];
    if (m.map_line < map_sigmas.size())
      line.world_sigma_m = map_sigmas[m.map_line];
    const int n = std::max(2, world_points);
    for (int k = 0; k < n; ++k)
      line.world.push_back(s.pointAt(t0 + (t1 - t0) * k / double(n - 1)));
    set.lines.push_back(std::move(line));
  }
  set.straight_lines = straightLinesOf(matches, image_lines, min_straight_length_px);
  return set;
}
}  // namespace

LineMatcherOptions::LineMatcherOptions()
{
  calibration.robust_noise_level = true;
  calibration.refinement.vertex_outlier_sigmas = 5.0;
  calibration.refinement.aspect_prior_sigma = 0.005;
  calibration.refinement.principal_point_prior_sigma = 0.03;
}

CameraModel cameraFromPrior(const CameraPrior& prior, int image_width, int image_height, double yaw_deg,
                            double pitch_deg, double fov_scale)
{
  Intrinsics in;
  const double hfov = std::clamp(prior.horizontal_fov_deg * fov_scale, 1.0, 179.0) * kDegToRad;
  in.fx = in.fy = 0.5 * image_width / std::tan(0.5 * hfov);
  in.cx = 0.5 * (image_width - 1);
  in.cy = 0.5 * (image_height - 1);
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

std::optional<std::pair<double, double>> visibleInterval(const CameraModel& camera, const Segment3d& segment,
                                                         int image_width, int image_height)
{
  constexpr int kSamples = 64;
  double t0 = 2.0;
  double t1 = -1.0;
  for (int k = 0; k <= kSamples; ++k)
  {
    const double t = k / double(kSamples);
    const auto m = camera.project(segment.pointAt(t));
    if (m && inside(*m, image_width, image_height))
    {
      t0 = std::min(t0, t);
      t1 = std::max(t1, t);
    }
  }
  if (t1 <= t0)
    return std::nullopt;
  return std::make_pair(t0, t1);
}

namespace
{
using PairSet = std::set<std::pair<size_t, size_t>>;  // (image line, map line) pairs

std::vector<LineMatch> matchLinesExcept(const std::vector<Segment3d>& map_lines,
                                        const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                        const CameraModel& camera, int image_width, int image_height,
                                        double max_angle_deg, double max_distance_px, const LineMatcherOptions& options,
                                        const PairSet& banned)
{
  const std::vector<ImageChord> image = summarize(image_lines);
  std::vector<ProjectedLine> projected;
  for (const auto& s : map_lines)
    projected.push_back(project(camera, s, image_width, image_height, 16));

  // All compatible pairs, then greedy by distance so that each image line and each 3D line is used once. An image
  // line with two candidates that fit about as well is ambiguous (repetitive texture: ceiling tiles, shelves) and
  // left out, unless the second is within near_duplicate_px too (the same edge twice in the map).
  std::vector<LineMatch> candidates;
  for (size_t i = 0; i < image.size(); ++i)
  {
    if (image[i].points->size() < 2 || image[i].length < options.min_image_length_px)
      continue;
    std::vector<LineMatch> own;
    for (size_t j = 0; j < projected.size(); ++j)
    {
      const ProjectedLine& p = projected[j];
      if (!p.visible || angleBetween(image[i].direction, p.direction) > max_angle_deg ||
          overlap(image[i], p) < options.min_overlap)
        continue;
      if (chordDistance(image[i], p) > 2.0 * max_distance_px)
        continue;
      const double d = meanDistance(image[i], p);
      if (d <= max_distance_px && !banned.count({i, j}))
        own.push_back({i, j, d});
    }
    std::sort(own.begin(), own.end(),
              [](const LineMatch& a, const LineMatch& b) { return a.distance_px < b.distance_px; });
    if (own.size() >= 2)
    {
      const double best = own[0].distance_px;
      const double second = own[1].distance_px;
      if (second > options.near_duplicate_px && second - best < std::max(0.5 * best, options.min_separation_px))
        continue;
    }
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
}  // namespace

std::vector<LineMatch> matchLines(const std::vector<Segment3d>& map_lines,
                                  const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                  const CameraModel& camera, int image_width, int image_height, double max_angle_deg,
                                  double max_distance_px, const LineMatcherOptions& options)
{
  return matchLinesExcept(map_lines, image_lines, camera, image_width, image_height, max_angle_deg, max_distance_px,
                          options, {});
}

namespace
{
// From one start camera: match, calibrate, re-match with tightened thresholds until the matches settle.
Expected<LineMatchResult> refineMatches(const std::vector<Segment3d>& map_lines, const std::vector<double>& map_sigmas,
                                        const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                        const CameraModel& start, int image_width, int image_height,
                                        const LineMatcherOptions& options, double initial_max_distance_px,
                                        const PairSet& banned,
                                        double abandon_above = std::numeric_limits<double>::infinity())
{
  const std::vector<ImageChord> image = summarize(image_lines);
  LineMatchResult result;
  result.search_camera = start;
  CameraModel camera = start;
  double max_distance = initial_max_distance_px;
  double max_angle = options.max_angle_deg;
  std::vector<LineMatch> previous;
  std::optional<CameraCalibration> calibrated;
  std::vector<LineMatch> used;
  CorrespondenceSet used_set;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration)
  {
    result.iterations = iteration + 1;
    std::vector<LineMatch> matches = matchLinesExcept(map_lines, image_lines, camera, image_width, image_height,
                                                      max_angle, max_distance, options, banned);
    const bool same =
        !previous.empty() && matches.size() == previous.size() &&
        std::equal(matches.begin(), matches.end(), previous.begin(), [](const LineMatch& a, const LineMatch& b) {
          return a.image_line == b.image_line && a.map_line == b.map_line;
        });
    if (same && calibrated)
    {
      result.converged = true;
      break;
    }
    CorrespondenceSet set = correspondencesOf(matches, map_lines, map_sigmas, image_lines, camera, image_width,
                                              image_height, options.world_points_per_line, 0.0);
    auto calibration = calibrateCamera(set, options.calibration, camera);
    if (!calibration)
    {
      if (calibrated)
        break;  // keep the last good calibration
      return Error(calibration.error().code(), "calibration on " + std::to_string(matches.size()) +
                                                   " matched lines failed: " + calibration.error().message());
    }
    trace(options, "  round %d: %zu matches (within %.1f px, %.1f deg), %zu inliers, RMS %.3f px, %s", iteration,
          matches.size(), max_distance, max_angle, calibration->inlier_count, calibration->reprojection.rms_px,
          describeCamera(calibration->camera).c_str());
    // A start that still explains the image worse than a known result after a few rounds is abandoned (the local
    // moves try many starts, most of them in vain).
    if (iteration + 1 >= options.abandon_after &&
        explanationScore(calibration->camera, map_lines, image, image_width, image_height, options.min_image_length_px,
                         options.explanation_cap_px) > abandon_above)
      return Error(ErrorCode::kNoSolution, "abandoned: explains the image worse than the current result");
    calibrated = *calibration;
    used = matches;
    used_set = set;
    previous = matches;
    camera = calibration->camera;
    // The threshold shrinks towards what the residuals call for, at most halving per iteration: a start far from
    // the truth moves step by step, with the lines it already explains, instead of locking onto a wrong subset.
    const double target = std::max(options.min_distance_px, options.distance_factor * calibration->reprojection.rms_px);
    max_distance = std::max(target, options.distance_shrink * max_distance);
    max_angle = std::max(2.0, std::min(options.max_angle_deg, 10.0 * calibration->reprojection.rms_px / 20.0 + 2.0));
  }
  if (!calibrated)
    return Error(ErrorCode::kNoSolution, "no calibration could be made from the matches");
  result.calibration = *calibrated;
  for (size_t k = 0; k < used.size(); ++k)
    if (k < calibrated->inlier_lines.size() && calibrated->inlier_lines[k])
      result.matches.push_back(used[k]);
  result.correspondences = used_set;
  result.candidate_matches = used;
  return result;
}
}  // namespace

namespace
{
// Each start refined (match, calibrate, re-match), the best explanation kept, then its influential matches checked.
Expected<LineMatchResult> matchFromStarts(const std::vector<Segment3d>& map_lines,
                                          const std::vector<double>& map_sigmas,
                                          const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                          const std::vector<CameraModel>& starts, int image_width, int image_height,
                                          const LineMatcherOptions& options, double initial_max_distance_px, bool hop);

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
}  // namespace

Expected<LineMatchResult> matchAndCalibrate(const std::vector<Segment3d>& map_lines,
                                            const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                            const CameraPrior& prior, int image_width, int image_height,
                                            const LineMatcherOptions& options,
                                            const std::vector<double>& map_line_sigmas_m)
{
  if (const Status valid = checkMatchInputs(map_lines, image_lines, image_width, image_height); !valid)
    return valid.error();
  if (!prior.position.allFinite() || !prior.direction.allFinite() || !(prior.direction.norm() > 0.0) ||
      !(prior.horizontal_fov_deg > 0.0 && prior.horizontal_fov_deg < 180.0))
    return Error(ErrorCode::kInvalidInput,
                 "the camera prior needs a finite position, a non-zero direction and a "
                 "horizontal field of view between 0 and 180 degrees");

  const std::vector<ImageChord> image = summarize(image_lines);
  std::vector<CameraModel> starts =
      searchPrior(map_lines, image, prior, image_width, image_height, options.search_steps, options.search_starts,
                  options.search_min_cap_px, options.search_cap_shrink);
  return matchFromStarts(map_lines, map_line_sigmas_m, image_lines, starts, image_width, image_height, options,
                         options.initial_max_distance_px, true);
}

Expected<LineMatchResult> matchAndCalibrateFrom(const std::vector<Segment3d>& map_lines,
                                                const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                                const CameraModel& start, int image_width, int image_height,
                                                const LineMatcherOptions& options,
                                                const std::vector<double>& map_line_sigmas_m)
{
  if (const Status valid = checkMatchInputs(map_lines, image_lines, image_width, image_height); !valid)
    return valid.error();
  return matchFromStarts(map_lines, map_line_sigmas_m, image_lines, {start}, image_width, image_height, options,
                         options.known_camera_max_distance_px, false);
}

namespace
{
// Cameras around a result (see the basin hopping in matchFromStarts): along the optical axis by +-step with the
// focal length scaled to keep the scale at the median depth Z of the matched lines, sideways (x and y of the camera)
// by +-step turned towards the point at depth Z on the axis, along the world axes by +-step, and the focal length
// alone by 1 +- focal_relative.
std::vector<CameraModel> hopCameras(const LineMatchResult& result, const std::vector<Segment3d>& map_lines, double step,
                                    double focal_relative)
{
  const CameraModel& camera = result.calibration.camera;
  std::vector<double> depths;
  for (const auto& m : result.matches)
  {
    const Segment3d& s = map_lines[m.map_line];
    depths.push_back((camera.pose().rotation * (0.5 * (s.a + s.b)) + camera.pose().translation).z());
  }
  std::vector<CameraModel> out;
  if (depths.empty())
    return out;
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  const double z = depths[depths.size() / 2];
  if (!(z > 2.0 * step))
    return out;
  const Eigen::Isometry3d world_from_camera = camera.pose().worldFromCamera();
  const Eigen::Matrix3d r = world_from_camera.linear();
  const Eigen::Vector3d c = world_from_camera.translation();
  const Eigen::Vector3d target = c + z * r.col(2);
  for (double sign : {-1.0, 1.0})
  {
    // Along the axis, focal compensated.
    CameraModel dolly = camera;
    Eigen::Isometry3d moved = world_from_camera;
    moved.translation() = c + sign * step * r.col(2);
    dolly.pose() = CameraPose::fromWorldFromCamera(moved);
    const double scale = (z - sign * step) / z;
    dolly.intrinsics().fx *= scale;
    dolly.intrinsics().fy *= scale;
    out.push_back(dolly);
    // Sideways, looking at the same point.
    for (int axis : {0, 1})
    {
      CameraModel side = camera;
      Eigen::Isometry3d turned = world_from_camera;
      turned.translation() = c + sign * step * r.col(axis);
      const Eigen::Vector3d forward = (target - turned.translation()).normalized();
      turned.linear() = Eigen::Matrix3d(Eigen::Quaterniond::FromTwoVectors(r.col(2), forward)) * r;
      side.pose() = CameraPose::fromWorldFromCamera(turned);
      out.push_back(side);
    }
    // Pure translations along the world axes: lines parallel to the move keep their images (vertical edges when
    // the height is wrong), so a camera off along them can match most lines and still be wrong.
    for (int axis : {0, 1, 2})
    {
      CameraModel shifted = camera;
      Eigen::Isometry3d moved = world_from_camera;
      moved.translation() = c + sign * step * Eigen::Vector3d::Unit(axis);
      shifted.pose() = CameraPose::fromWorldFromCamera(moved);
      out.push_back(shifted);
    }
    // Focal length alone.
    CameraModel zoom = camera;
    zoom.intrinsics().fx *= 1.0 + sign * focal_relative;
    zoom.intrinsics().fy *= 1.0 + sign * focal_relative;
    out.push_back(zoom);
  }
  return out;
}

Expected<LineMatchResult> matchFromStarts(const std::vector<Segment3d>& map_lines,
                                          const std::vector<double>& map_sigmas,
                                          const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                          const std::vector<CameraModel>& starts, int image_width, int image_height,
                                          const LineMatcherOptions& options, double initial_max_distance_px, bool hop)
{
  const std::vector<ImageChord> image = summarize(image_lines);
  const auto scoreOf = [&](const LineMatchResult& r) {
    return explanationScore(r.calibration.camera, map_lines, image, image_width, image_height,
                            options.min_image_length_px, options.explanation_cap_px);
  };
  const auto describe = [&](const char* what, const LineMatchResult& r, double score) {
    trace(options, "%s: score %.3f, %zu matches, RMS %.3f px, %s", what, score, r.matches.size(),
          r.calibration.reprojection.rms_px, describeCamera(r.calibration.camera).c_str());
  };
  std::optional<LineMatchResult> best;
  double best_score = std::numeric_limits<double>::infinity();
  std::string last_error = "no start camera";
  for (const CameraModel& start : starts)
  {
    trace(options, "start %s", describeCamera(start).c_str());
    auto candidate = refineMatches(map_lines, map_sigmas, image_lines, start, image_width, image_height, options,
                                   initial_max_distance_px, {});
    if (!candidate)
    {
      last_error = candidate.error().message();
      continue;
    }
    const double score = scoreOf(*candidate);
    describe("start", *candidate, score);
    if (score < best_score)
    {
      best_score = score;
      best = std::move(*candidate);
    }
  }
  if (!best)
    return Error(ErrorCode::kNoSolution, "no start of the prior search led to a calibration: " + last_error);

  // Two local moves, alternated while either explains the image better (lower score by min_score_gain), at most
  // max_local_rounds times:
  // - Basin hopping: the result of a start can be a wrong local optimum next to the right one (a camera a little
  //   farther with a longer focal length, or shifted along a repeated structure, matches most lines). The camera is
  //   moved by the typical size of such errors, along the optical axis with the focal length compensated (the scene
  //   at the matched lines' median depth keeps its scale) and sideways with the view turned to keep that depth's
  //   centre, and the matching redone from each.
  // - Influence check: a wrong match with enough leverage pulls the camera onto itself; its own residual is small,
  //   the others' grow a little. Its influence (how far the camera moves without it) gives it away: the most
  //   influential matches are each banned in turn and the matching redone from the current camera.
  PairSet banned;
  const auto hopRound = [&]() {
    bool improved = false;
    std::vector<CameraModel> hops;
    for (double scale : options.hop_scales)
    {
      const auto more =
          hopCameras(*best, map_lines, scale * options.hop_position_m, scale * options.hop_focal_relative);
      hops.insert(hops.end(), more.begin(), more.end());
    }
    for (const CameraModel& camera : hops)
    {
      auto candidate = refineMatches(map_lines, map_sigmas, image_lines, camera, image_width, image_height, options,
                                     options.hop_max_distance_px, {}, best_score);
      if (!candidate)
        continue;
      const double score = scoreOf(*candidate);
      describe("hop", *candidate, score);
      if (score < best_score - options.min_score_gain)
      {
        best_score = score;
        best = std::move(*candidate);
        banned.clear();
        improved = true;
      }
    }
    return improved;
  };
  const auto influenceRound = [&]() {
    const auto& refinement = best->calibration.refinement;
    if (!refinement || refinement->line_influence.size() != best->matches.size())
      return false;
    std::vector<size_t> order(best->matches.size());
    std::iota(order.begin(), order.end(), 0);
    const auto influence = [&](size_t k) {
      const double v = refinement->line_influence[k];
      return std::isnan(v) ? 0.0 : v;
    };
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return influence(a) > influence(b); });
    const double distance =
        std::max(options.min_distance_px, options.distance_factor * best->calibration.reprojection.rms_px);
    for (size_t n = 0; n < order.size() && n < static_cast<size_t>(options.influence_candidates); ++n)
    {
      const LineMatch& m = best->matches[order[n]];
      if (influence(order[n]) < options.min_influence)
        break;
      PairSet trial = banned;
      trial.insert({m.image_line, m.map_line});
      auto candidate = refineMatches(map_lines, map_sigmas, image_lines, best->calibration.camera, image_width,
                                     image_height, options, distance, trial);
      if (!candidate)
        continue;
      const double score = scoreOf(*candidate);
      trace(options, "without image line %zu - map line %zu (influence %.3g):", m.image_line, m.map_line,
            influence(order[n]));
      describe("  result", *candidate, score);
      if (score < best_score - options.min_score_gain)
      {
        best_score = score;
        best = std::move(*candidate);
        banned = std::move(trial);
        return true;
      }
    }
    return false;
  };
  for (int round = 0; round < options.max_local_rounds; ++round)
  {
    const bool hopped = hop && options.basin_hopping && hopRound();
    const bool pruned = influenceRound();
    if (!hopped && !pruned)
      break;
  }
  // The chosen result calibrated once more with the unmatched image lines as plumb lines (only here: each adds two
  // parameters, too many for the exploration above).
  if (options.min_straight_line_px > 0.0)
  {
    CorrespondenceSet set = best->correspondences;
    set.straight_lines = straightLinesOf(best->candidate_matches, image_lines, options.min_straight_line_px);
    if (!set.straight_lines.empty())
      if (auto polished = calibrateCamera(set, options.calibration, best->calibration.camera))
      {
        trace(options, "with %zu plumb lines: %zu -> %zu inlier lines, lambda %.4g -> %.4g, %s",
              set.straight_lines.size(), best->calibration.inlier_count, polished->inlier_count,
              best->calibration.camera.distortion().lambda, polished->camera.distortion().lambda,
              describeCamera(polished->camera).c_str());
        best->calibration = *polished;
        best->correspondences = set;
        best->matches.clear();
        for (size_t k = 0; k < best->candidate_matches.size(); ++k)
          if (k < polished->inlier_lines.size() && polished->inlier_lines[k])
            best->matches.push_back(best->candidate_matches[k]);
      }
  }
  return *best;
}
}  // namespace

}  // namespace insitu_calibration
