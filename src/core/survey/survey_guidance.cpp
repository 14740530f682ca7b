#include "insitu_calibration/survey/survey_guidance.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/robust_statistics.h"
#include "insitu_calibration/survey/fixed_camera.h"

namespace insitu_calibration
{
namespace
{
// A height counts as in the Xtion's view this far inside its vertical field of view (a line at the image border is
// hardly extracted).
constexpr double kXtionFovMarginDeg = 2.0;
// An advised pitch stays this far inside the pitches that do (a mount is not set finer).
constexpr double kPitchMarginDeg = 3.0;

// The projected map lines drawn `half_width_px` wide: a non-zero pixel is within that distance of a map line.
cv::Mat projectedMapMask(const CameraModel& camera, int width, int height, const std::vector<Segment3d>& map_lines,
                         double half_width_px)
{
  cv::Mat mask(height, width, CV_8U, cv::Scalar(0));
  const int thickness = std::max(1, static_cast<int>(std::lround(2.0 * half_width_px)) + 1);
  for (const auto& segment : map_lines)
  {
    const auto interval = visibleInterval(camera, segment, width, height);
    if (!interval)
      continue;
    std::vector<cv::Point> curve;
    for (int k = 0; k <= 24; ++k)
      if (const auto m =
              camera.project(segment.pointAt(interval->first + (interval->second - interval->first) * k / 24.0)))
        curve.emplace_back(cvRound(m->x()), cvRound(m->y()));
    if (curve.size() >= 2)
      cv::polylines(mask, curve, false, cv::Scalar(255), thickness);
  }
  return mask;
}

// Per cell: the image lines' samples and the unexplained ones; per line, its unexplained samples per cell.
struct CellSamples
{
  std::vector<int> total;
  std::vector<int> unexplained;
  std::vector<std::map<int, int>> line_unexplained;  // per image line: cell -> unexplained samples
  std::vector<int> line_total;
};

CellSamples sampleImageLines(const std::vector<std::vector<Eigen::Vector2d>>& lines, const cv::Mat& explained,
                             const SurveyGuidance& g, double step_px)
{
  CellSamples s;
  s.total.assign(g.cells.size(), 0);
  s.unexplained.assign(g.cells.size(), 0);
  s.line_unexplained.resize(lines.size());
  s.line_total.assign(lines.size(), 0);
  auto sample = [&](size_t line, const Eigen::Vector2d& p) {
    const int x = cvRound(p.x()), y = cvRound(p.y());
    if (x < 0 || y < 0 || x >= g.width || y >= g.height)
      return;
    const int cell =
        std::min(g.rows - 1, y * g.rows / g.height) * g.columns + std::min(g.columns - 1, x * g.columns / g.width);
    ++s.total[cell];
    ++s.line_total[line];
    if (explained.at<uint8_t>(y, x) == 0)
    {
      ++s.unexplained[cell];
      ++s.line_unexplained[line][cell];
    }
  };
  for (size_t l = 0; l < lines.size(); ++l)
    for (size_t j = 1; j < lines[l].size(); ++j)
    {
      const Eigen::Vector2d a = lines[l][j - 1], b = lines[l][j];
      const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step_px)));
      for (int k = (j == 1 ? 0 : 1); k <= n; ++k)
        sample(l, a + (b - a) * (static_cast<double>(k) / n));
    }
  return s;
}

// Neighbouring (4-connected) unmapped cells.
std::vector<std::vector<int>> unmappedComponents(const SurveyGuidance& g)
{
  std::vector<std::vector<int>> components;
  std::vector<bool> seen(g.cells.size(), false);
  for (size_t start = 0; start < g.cells.size(); ++start)
  {
    if (seen[start] || g.cells[start] != GuidanceCell::kUnmapped)
      continue;
    std::vector<int> component, stack{static_cast<int>(start)};
    seen[start] = true;
    while (!stack.empty())
    {
      const int c = stack.back();
      stack.pop_back();
      component.push_back(c);
      const int row = c / g.columns, col = c % g.columns;
      const int neighbours[4][2] = {{row - 1, col}, {row + 1, col}, {row, col - 1}, {row, col + 1}};
      for (const auto& n : neighbours)
      {
        if (n[0] < 0 || n[1] < 0 || n[0] >= g.rows || n[1] >= g.columns)
          continue;
        const int k = n[0] * g.columns + n[1];
        if (!seen[k] && g.cells[k] == GuidanceCell::kUnmapped)
        {
          seen[k] = true;
          stack.push_back(k);
        }
      }
    }
    std::sort(component.begin(), component.end());
    components.push_back(component);
  }
  return components;
}

// "top left", "right", "centre", ...: where the cells' mean lies in thirds of the view; "whole" for most of it.
std::string describePlace(const SurveyGuidance& g, const std::vector<int>& cells)
{
  if (cells.size() * 3 >= g.cells.size() * 2)
    return "whole";
  double x = 0.0, y = 0.0;
  for (int c : cells)
  {
    x += (c % g.columns + 0.5) / g.columns;
    y += (c / g.columns + 0.5) / g.rows;
  }
  x /= cells.size();
  y /= cells.size();
  const std::string vertical = y < 1.0 / 3.0 ? "top" : (y > 2.0 / 3.0 ? "bottom" : "");
  const std::string horizontal = x < 1.0 / 3.0 ? "left" : (x > 2.0 / 3.0 ? "right" : "");
  if (vertical.empty() && horizontal.empty())
    return "centre";
  return vertical.empty() ? horizontal : (horizontal.empty() ? vertical : vertical + " " + horizontal);
}

struct FloorBox
{
  Eigen::Vector2d min = Eigen::Vector2d::Constant(-std::numeric_limits<double>::infinity());
  Eigen::Vector2d max = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  // The point moved into the box shrunk by `inset` (its centre when the box is narrower than twice that).
  Eigen::Vector2d clamp(const Eigen::Vector2d& p, double inset) const
  {
    Eigen::Vector2d out;
    for (int i = 0; i < 2; ++i)
      out[i] =
          max[i] - min[i] > 2.0 * inset ? std::clamp(p[i], min[i] + inset, max[i] - inset) : 0.5 * (min[i] + max[i]);
    return out;
  }
};

FloorBox mapExtent(const std::vector<Segment3d>& map_lines, double margin_m)
{
  FloorBox box;
  if (map_lines.empty())
    return box;
  box.min = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  box.max = -box.min;
  for (const auto& s : map_lines)
    for (const Eigen::Vector3d& p : {s.a, s.b})
    {
      box.min = box.min.cwiseMin(p.head<2>());
      box.max = box.max.cwiseMax(p.head<2>());
    }
  box.min.array() -= margin_m;
  box.max.array() += margin_m;
  return box;
}

// Where a world ray from `centre` meets the floor z = 0, stopped at max_range_m (horizontally) and at the map's
// extent when the camera is inside it; z is the ray's height there (0 on the floor; at most the camera's: a ray
// that rises meets the ceiling above the camera's height at the latest).
Eigen::Vector3d floorPoint(const Eigen::Vector3d& centre, const Eigen::Vector3d& direction, const FloorBox& box,
                           double max_range_m)
{
  const Eigen::Vector2d horizontal = direction.head<2>();
  const double h = horizontal.norm();
  if (h < 1e-9)
    return {centre.x(), centre.y(), 0.0};
  const auto at = [&](double reach) -> Eigen::Vector3d {
    const Eigen::Vector2d p = centre.head<2>() + std::max(0.0, reach) * horizontal / h;
    const double z = std::clamp(centre.z() + direction.z() / h * std::max(0.0, reach), 0.0, std::max(0.0, centre.z()));
    return {p.x(), p.y(), z};
  };
  const Eigen::Vector2d u = horizontal / h;
  double reach = max_range_m;
  if (direction.z() < 0.0 && centre.z() > 0.0)
    reach = std::min(reach, centre.z() / -direction.z() * h);
  // Where the horizontal ray leaves the map's extent (slabs), when it crosses it at all.
  double enter = 0.0, leave = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 2; ++i)
  {
    if (std::abs(u[i]) < 1e-12)
    {
      if (centre[i] < box.min[i] || centre[i] > box.max[i])
        return at(reach);
      continue;
    }
    const double t0 = (box.min[i] - centre[i]) / u[i], t1 = (box.max[i] - centre[i]) / u[i];
    enter = std::max(enter, std::min(t0, t1));
    leave = std::min(leave, std::max(t0, t1));
  }
  if (leave >= enter)
    reach = std::min(reach, leave);
  return at(reach);
}

// The polygon's area centroid (its vertices' mean when degenerate).
Eigen::Vector2d centroidOf(const std::vector<Eigen::Vector2d>& polygon)
{
  double area = 0.0;
  Eigen::Vector2d c = Eigen::Vector2d::Zero(), mean = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < polygon.size(); ++i)
  {
    const Eigen::Vector2d& p = polygon[i];
    const Eigen::Vector2d& q = polygon[(i + 1) % polygon.size()];
    const double cross = p.x() * q.y() - q.x() * p.y();
    area += cross;
    c += (p + q) * cross;
    mean += p;
  }
  if (std::abs(area) < 1e-9)
    return mean / std::max<size_t>(1, polygon.size());
  return c / (3.0 * area);
}

// The region's rays' points (floorPoint; a 3 x 3 grid of pixels per cell).
std::vector<Eigen::Vector3d> regionPoints(const CameraModel& camera, const SurveyGuidance& g, const FloorBox& box,
                                          const SurveyGuidanceOptions& options, const UnmappedRegion& region)
{
  const Eigen::Vector3d centre = camera.pose().center();
  const Eigen::Matrix3d world_from_camera = camera.pose().rotation.transpose();
  std::vector<Eigen::Vector3d> points;
  for (int c : region.cells)
  {
    const cv::Rect r = g.cellRect(c);
    for (int i = 0; i <= 2; ++i)
      for (int j = 0; j <= 2; ++j)
        if (const auto ray = camera.backProject({r.x + 0.5 * i * (r.width - 1), r.y + 0.5 * j * (r.height - 1)}))
          points.push_back(floorPoint(centre, world_from_camera * *ray, box, options.max_range_m));
  }
  return points;
}

// Whether the Xtion at one of its mounts has a point in its view from `stand` looking along `look` (its sweep
// included), within its reach.
bool inXtionView(const Eigen::Vector3d& p, const Eigen::Vector2d& stand, const Eigen::Vector2d& look,
                 const std::vector<XtionView>& xtions, const SurveyGuidanceOptions& options)
{
  const double deg = 180.0 / M_PI;
  const Eigen::Vector2d v = p.head<2>() - stand;
  const double r = v.norm();
  if (r < 0.3)
    return false;
  const double bearing = std::acos(std::clamp(v.dot(look) / (r * look.norm()), -1.0, 1.0)) * deg;
  for (const XtionView& xtion : xtions)
  {
    const double rise = p.z() - xtion.height_m;
    const double elevation = std::atan2(rise, r) * deg - xtion.pitch_deg;
    if (std::hypot(r, rise) <= options.xtion_reach_m &&
        bearing <= xtion.horizontal_half_fov_deg + options.look_sweep_deg &&
        std::abs(elevation) <= xtion.vertical_half_fov_deg - kXtionFovMarginDeg)
      return true;
  }
  return false;
}

// The share of the points the Xtion has in its view (at one of its mounts) from `stand` looking at `target`.
double xtionShare(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector2d& stand,
                  const Eigen::Vector2d& target, const SurveyGuidanceOptions& options)
{
  const Eigen::Vector2d look = target - stand;
  if (look.norm() < 1e-6 || points.empty())
    return 0.0;
  const auto seen = std::count_if(points.begin(), points.end(), [&](const Eigen::Vector3d& p) {
    return inXtionView(p, stand, look, options.xtions, options);
  });
  return static_cast<double>(seen) / points.size();
}

// The standpoint `standoff` before the target on the line from the camera's foot (at the foot when the target is
// nearer), inside the map's extent (a camera hangs on a wall; a far region's standpoint may lie beyond it).
Eigen::Vector2d standpointAt(const Eigen::Vector2d& foot, const Eigen::Vector2d& target, const Eigen::Vector2d& toward,
                             double standoff, const FloorBox& box, const SurveyGuidanceOptions& options)
{
  const Eigen::Vector2d stand = (target - foot).norm() > standoff ? Eigen::Vector2d(target - standoff * toward) : foot;
  return box.clamp(stand, options.map_margin_m + options.robot_clearance_m);
}

// The shares of the points at heights no mount has in view within its reach: above (higher than the lowest of the
// mounts' highest heights: above every view, or between two) and below; and the mount a new pitch starts from.
void measureXtionHeights(const std::vector<Eigen::Vector3d>& points, const SurveyGuidanceOptions& options,
                         UnmappedRegion* region)
{
  const double reach = options.xtion_reach_m;
  auto inSomeView = [&](double z) {
    return std::any_of(options.xtions.begin(), options.xtions.end(),
                       [&](const XtionView& x) { return z >= x.lowestInReach(reach) && z <= x.highestInReach(reach); });
  };
  double lowest_top = std::numeric_limits<double>::infinity();
  for (const XtionView& x : options.xtions)
    lowest_top = std::min(lowest_top, x.highestInReach(reach));
  size_t above = 0, below = 0;
  for (const Eigen::Vector3d& p : points)
    if (!inSomeView(p.z()))
      (p.z() > lowest_top ? above : below) += 1;
  const double n = std::max<size_t>(1, points.size());
  region->xtion_above_share = above / n;
  region->xtion_below_share = below / n;
  region->xtion_reach_m = reach;
  region->xtions = options.xtions;
  region->mount_limits = options.mount_limits;
  const bool up = above >= below;
  region->xtion =
      *std::max_element(options.xtions.begin(), options.xtions.end(), [&](const XtionView& a, const XtionView& b) {
        return up ? a.highestInReach(reach) < b.highestInReach(reach) : a.lowestInReach(reach) > b.lowestInReach(reach);
      });
}

// Whether the robot has been within visited_radius_m of a point (any point, when where it has been is not known).
bool nearVisited(const Eigen::Vector2d& p, const SurveyGuidanceOptions& options)
{
  if (options.visited.empty())
    return true;
  for (const Eigen::Vector2d& v : options.visited)
    if ((v - p).squaredNorm() <= options.visited_radius_m * options.visited_radius_m)
      return true;
  return false;
}

// The standpoint from which the Xtion sees most of the region's points: standoffs from min_standoff_m to
// max_standoff_m in twelve directions around the target (a region under the camera is seen best looking back
// towards the camera's wall; off the line from the camera's foot only where the robot has been, so that it is free
// floor and on the same side of the walls). Of those within 0.05 of the best share, the one closest to the fixed
// standpoint (robot_standoff_m on the line from the camera's foot; a radian of direction counts as a metre of
// standoff).
Eigen::Vector2d chooseStandpoint(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector2d& foot,
                                 const Eigen::Vector2d& target, const Eigen::Vector2d& toward, const FloorBox& box,
                                 const SurveyGuidanceOptions& options, UnmappedRegion* region)
{
  struct Candidate
  {
    Eigen::Vector2d stand;
    double share, cost;
  };
  std::vector<Candidate> candidates;
  const double inset = options.map_margin_m + options.robot_clearance_m;
  const double back = std::atan2(-toward.y(), -toward.x());
  for (int k = 0; k < 12; ++k)
  {
    const double turn = k <= 6 ? k * M_PI / 6.0 : (k - 12) * M_PI / 6.0;  // 0, +-30, ..., 180 deg from `back`
    const Eigen::Vector2d away(std::cos(back + turn), std::sin(back + turn));
    for (double d = options.min_standoff_m; d <= options.max_standoff_m + 1e-9; d += 0.25)
    {
      const Eigen::Vector2d stand =
          k == 0 ? standpointAt(foot, target, toward, d, box, options) : box.clamp(target + d * away, inset);
      if (k != 0 && !nearVisited(stand, options))
        continue;
      candidates.push_back(
          {stand, xtionShare(points, stand, target, options), std::abs(d - options.robot_standoff_m) + std::abs(turn)});
    }
  }
  double best = 0.0;
  for (const Candidate& c : candidates)
    best = std::max(best, c.share);
  const Candidate* chosen = nullptr;
  for (const Candidate& c : candidates)
    if (c.share >= best - 0.05 && (!chosen || c.cost < chosen->cost))
      chosen = &c;
  region->xtion_share = chosen->share;
  return chosen->stand;
}

// The floor polygon of a region, and where the robot should stand and look.
void placeOnFloor(const CameraModel& camera, const SurveyGuidance& g, const FloorBox& box,
                  const SurveyGuidanceOptions& options, UnmappedRegion* region)
{
  const std::vector<Eigen::Vector3d> points = regionPoints(camera, g, box, options, *region);
  if (points.empty())
    return;
  std::vector<cv::Point2f> flat;
  region->structure_min_height_m = std::numeric_limits<double>::infinity();
  region->structure_max_height_m = 0.0;
  for (const Eigen::Vector3d& p : points)
  {
    flat.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
    region->structure_min_height_m = std::min(region->structure_min_height_m, p.z());
    region->structure_max_height_m = std::max(region->structure_max_height_m, p.z());
  }
  std::vector<cv::Point2f> hull;
  cv::convexHull(flat, hull, false);
  for (const auto& p : hull)
    region->floor_polygon.emplace_back(p.x, p.y);
  const Eigen::Vector2d target = centroidOf(region->floor_polygon);
  const Eigen::Vector2d foot = camera.pose().center().head<2>();
  region->camera_height_m = options.camera_height_m.value_or(camera.pose().center().z());
  Eigen::Vector2d d = target - foot;
  if (d.norm() < 1e-6)
    d = (camera.pose().rotation.transpose() * Eigen::Vector3d::UnitZ()).head<2>();
  const Eigen::Vector2d toward = d.norm() > 1e-9 ? Eigen::Vector2d(d.normalized()) : Eigen::Vector2d::UnitX();
  if (!options.xtions.empty())
  {
    measureXtionHeights(points, options, region);
    region->robot_position = chooseStandpoint(points, foot, target, toward, box, options, region);
  }
  else
    region->robot_position = standpointAt(foot, target, toward, options.robot_standoff_m, box, options);
  const Eigen::Vector2d look = target - region->robot_position;
  region->look_direction = look.norm() > 1e-6 ? Eigen::Vector2d(look.normalized()) : toward;
}

// Regions of unmapped cells placed on the floor, split where one standpoint cannot have most of a region in view.
struct RegionPlacer
{
  const CameraModel& camera;
  const SurveyGuidance& g;
  const FloorBox& box;
  const SurveyGuidanceOptions& options;
  const std::vector<size_t>& lines_per_cell;

  // None when the cells hold no image line of their own (a few unexplained pieces of lines that count elsewhere).
  std::optional<UnmappedRegion> place(std::vector<int> cells) const
  {
    UnmappedRegion region;
    region.cells = std::move(cells);
    for (int c : region.cells)
      region.image_lines += lines_per_cell[c];
    if (region.image_lines == 0)
      return std::nullopt;
    region.where = describePlace(g, region.cells);
    placeOnFloor(camera, g, box, options, &region);
    return region;
  }

  // The region's two halves across rows (by_rows) or columns: the cells before and after the median row (column).
  std::optional<std::pair<UnmappedRegion, UnmappedRegion>> halves(const UnmappedRegion& region, bool by_rows) const
  {
    std::vector<int> keys;
    for (int c : region.cells)
      keys.push_back(by_rows ? c / g.columns : c % g.columns);
    std::vector<int> sorted = keys;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const int cut = sorted[sorted.size() / 2];
    std::vector<int> first, second;
    for (size_t k = 0; k < keys.size(); ++k)
      (keys[k] < cut ? first : second).push_back(region.cells[k]);
    auto a = place(std::move(first)), b = place(std::move(second));
    if (!a || !b)
      return std::nullopt;
    return std::make_pair(std::move(*a), std::move(*b));
  }

  // The region into out, cut in halves (recursively, at most `parts` parts) while a cut gains enough of its lines'
  // points in the Xtion's view.
  void splitForStandpoints(UnmappedRegion region, int parts, std::vector<UnmappedRegion>* out) const
  {
    const bool split = !options.xtions.empty() && parts >= 2 && region.cells.size() >= 2 && region.xtion_share >= 0.0 &&
                       region.xtion_share < options.split_below_share;
    std::optional<std::pair<UnmappedRegion, UnmappedRegion>> best;
    double best_share = region.xtion_share + options.min_split_gain;
    for (const bool by_rows : {true, false})
    {
      auto h = split ? halves(region, by_rows) : std::nullopt;
      if (!h)
        continue;
      const double lines = static_cast<double>(h->first.image_lines + h->second.image_lines);
      const double share =
          (h->first.image_lines * h->first.xtion_share + h->second.image_lines * h->second.xtion_share) / lines;
      if (share >= best_share)
      {
        best_share = share;
        best = std::move(h);
      }
    }
    if (!best)
    {
      out->push_back(std::move(region));
      return;
    }
    splitForStandpoints(std::move(best->first), parts / 2, out);
    splitForStandpoints(std::move(best->second), parts - parts / 2, out);
  }
};

void classifyCells(const CellSamples& s, const cv::Mat& map_presence, const SurveyGuidanceOptions& options,
                   SurveyGuidance* g)
{
  for (size_t c = 0; c < g->cells.size(); ++c)
  {
    const bool has_lines = s.total[c] >= options.min_samples;
    if (has_lines && s.unexplained[c] >= options.min_unexplained_share * s.total[c])
      g->cells[c] = GuidanceCell::kUnmapped;
    else if (!has_lines && cv::countNonZero(map_presence(g->cellRect(static_cast<int>(c)))) == 0)
      g->cells[c] = GuidanceCell::kEmpty;
    else
      g->cells[c] = GuidanceCell::kCovered;
  }
}

// Each image line mostly unexplained counts once, in the cell that holds most of its unexplained samples.
std::vector<size_t> unexplainedLinesPerCell(const CellSamples& s, const SurveyGuidanceOptions& options, size_t cells)
{
  std::vector<size_t> per_cell(cells, 0);
  for (size_t l = 0; l < s.line_total.size(); ++l)
  {
    int unexplained = 0, best_cell = -1, best = 0;
    for (const auto& [cell, n] : s.line_unexplained[l])
    {
      unexplained += n;
      if (n > best)
        best = n, best_cell = cell;
    }
    if (best_cell >= 0 && unexplained >= options.min_unexplained_share * s.line_total[l])
      ++per_cell[best_cell];
  }
  return per_cell;
}
}  // namespace

double XtionView::highestInReach(double reach_m) const
{
  // Along the upper edge of the view the height changes by sin(elevation) per metre of range.
  const double edge = (pitch_deg + vertical_half_fov_deg - kXtionFovMarginDeg) * M_PI / 180.0;
  return height_m + reach_m * std::max(0.0, std::sin(edge));
}

double XtionView::lowestInReach(double reach_m) const
{
  const double edge = (pitch_deg - vertical_half_fov_deg + kXtionFovMarginDeg) * M_PI / 180.0;
  return height_m - reach_m * std::max(0.0, -std::sin(edge));
}

std::optional<double> XtionView::pitchToSee(double low_m, double high_m, double reach_m) const
{
  const double deg = 180.0 / M_PI, half = vertical_half_fov_deg - kXtionFovMarginDeg;
  if (reach_m <= 0.0 || high_m - height_m > reach_m || height_m - low_m > reach_m || low_m > high_m)
    return std::nullopt;
  // The upper edge must rise to high_m and the lower one fall to low_m at the reach (highestInReach,
  // lowestInReach); a height above the Xtion's comes into view from nearer whatever the lower edge does.
  const double lowest_pitch = high_m > height_m ? std::asin((high_m - height_m) / reach_m) * deg - half : -90.0 + half;
  const double highest_pitch = low_m < height_m ? half - std::asin((height_m - low_m) / reach_m) * deg : 90.0 - half;
  if (lowest_pitch > highest_pitch)
    return std::nullopt;
  // The least change of pitch that does it, kept up to 3 deg inside the pitches that do (a mount is not set finer).
  const double margin = std::min(kPitchMarginDeg, 0.5 * (highest_pitch - lowest_pitch));
  return std::clamp(pitch_deg, lowest_pitch + margin, highest_pitch - margin);
}

cv::Rect SurveyGuidance::cellRect(int cell) const
{
  const int row = cell / columns, col = cell % columns;
  const int x0 = col * width / columns, x1 = (col + 1) * width / columns;
  const int y0 = row * height / rows, y1 = (row + 1) * height / rows;
  return {x0, y0, x1 - x0, y1 - y0};
}

size_t SurveyGuidance::count(GuidanceCell kind) const
{
  return static_cast<size_t>(std::count(cells.begin(), cells.end(), kind));
}

namespace
{
// The heights a new mount is tried at: the Xtion's own, then a tenth of a metre apart away from it (up for a region
// above, down below) within the limits.
std::vector<double> mountHeightsToTry(double height_m, bool up, const XtionMountLimits& limits)
{
  std::vector<double> heights{height_m};
  const double step = up ? 0.1 : -0.1;
  const double tenths = up ? std::floor(height_m * 10.0 + 1e-6) : std::ceil(height_m * 10.0 - 1e-6);
  const double first = std::clamp(tenths / 10.0 + step, limits.min_height_m, limits.max_height_m);
  for (double h = first;
       (h - height_m) * step > 0.0 && h >= limits.min_height_m - 1e-9 && h <= limits.max_height_m + 1e-9; h += step)
    heights.push_back(h);
  return heights;
}
}  // namespace

// The heights are lower bounds (a ray meets furniture or a wall's upper part before the floor or the map's edge), so
// a region above the Xtion is wanted in view up to the camera's own height, where its lines may well be. What the
// survey's mounts see stays in their recordings: a new mount that adds only the rest also does.
std::optional<XtionMount> UnmappedRegion::mountToSee() const
{
  if (xtion_share < 0.0)
    return std::nullopt;
  const bool above = xtion_above_share >= xtion_below_share;
  const double low = structure_min_height_m, top = structure_max_height_m;
  const double high = above ? std::max(top, camera_height_m) : top;
  double seen_top = low, seen_bottom = top;
  for (const XtionView& x : xtions)
  {
    seen_top = std::max(seen_top, x.highestInReach(xtion_reach_m));
    seen_bottom = std::min(seen_bottom, x.lowestInReach(xtion_reach_m));
  }
  std::vector<std::pair<double, double>> bands{{low, high}, {low, top}};
  if (above)
    bands.insert(bands.end(), {{seen_top, high}, {seen_top, top}});
  else
    bands.emplace_back(low, seen_bottom);
  const std::vector<double> heights = mountHeightsToTry(xtion.height_m, above, mount_limits);
  for (const double height : heights)
    for (const auto& [band_low, band_high] : bands)
      if (const auto mount = mountWithin(height, band_low, band_high))
        return mount;
  // No mount within the limits has all of them in view within reach (a high wall, a short reach): the first that
  // adds a useful part of the heights no mount has in view, pitched to the limit.
  for (const double height : heights)
  {
    XtionView limit = xtion;
    limit.height_m = height;
    const double steepest = mount_limits.max_abs_pitch_deg - kPitchMarginDeg;  // pitchToSee keeps its margin
    limit.pitch_deg = above ? steepest : -steepest;
    const double band_low = above ? std::max(low, seen_top) : std::max(low, limit.lowestInReach(xtion_reach_m)),
                 band_high = above ? std::min(high, limit.highestInReach(xtion_reach_m)) : std::min(top, seen_bottom);
    if (band_high - band_low >= kMinAdvisedBandM)
      if (const auto mount = mountWithin(height, band_low, band_high))
        return mount;
  }
  return std::nullopt;
}

std::optional<XtionMount> UnmappedRegion::mountWithin(double height_m, double low_m, double high_m) const
{
  XtionView view = xtion;
  view.height_m = height_m;
  const std::optional<double> pitch = view.pitchToSee(low_m, high_m, xtion_reach_m);
  if (!pitch || std::abs(std::round(*pitch)) > mount_limits.max_abs_pitch_deg)
    return std::nullopt;
  return XtionMount{height_m, std::round(*pitch) + 0.0, height_m != xtion.height_m};  // + 0.0: no "-0"
}

namespace
{
// What brings a region out of the Xtion's reach into its view: the mount that has the region's heights in view
// within its reach (UnmappedRegion::mountToSee), else a mount beyond the limits. In words for the sentence, with the
// heights the mount then sees, or in short for the hint picture's legend (a line of it fits a 640 px image).
std::string xtionRemedy(const UnmappedRegion& r, bool in_short)
{
  const std::optional<XtionMount> mount = r.mountToSee();
  char text[160];
  if (!mount)
  {
    const bool up = r.xtion_above_share >= r.xtion_below_share;
    const double limit = up ? r.mount_limits.max_height_m : r.mount_limits.min_height_m;
    if (in_short)
      std::snprintf(text, sizeof(text), "mount it %s than %.1f m", up ? "higher" : "lower", limit);
    else
      std::snprintf(text, sizeof(text), "mount the Xtion %s than %.1f m (or pitched more than %.0f deg)",
                    up ? "higher" : "lower", limit, r.mount_limits.max_abs_pitch_deg);
    return text;
  }
  XtionView mounted = r.xtion;
  mounted.height_m = mount->height_m;
  mounted.pitch_deg = mount->pitch_deg;
  const bool same_height = !mount->new_height;
  if (in_short && same_height)
    std::snprintf(text, sizeof(text), "pitch it to %+.0f deg", mounted.pitch_deg);
  else if (in_short)
    std::snprintf(text, sizeof(text), "mount it %.1f m high, pitched %+.0f deg", mounted.height_m, mounted.pitch_deg);
  else if (same_height)
    std::snprintf(text, sizeof(text), "pitch the Xtion to about %+.0f deg", mounted.pitch_deg);
  else
    std::snprintf(text, sizeof(text), "mount the Xtion about %.1f m high and pitch it to about %+.0f deg",
                  mounted.height_m, mounted.pitch_deg);
  if (in_short)
    return text;
  char band[64];
  std::snprintf(band, sizeof(band), " (it then has %.1f-%.1f m in view)",
                std::max(0.0, mounted.lowestInReach(r.xtion_reach_m)), mounted.highestInReach(r.xtion_reach_m));
  return std::string(text) + band;
}

// The survey's mounts: "0.60 m high and pitched +10 deg", or "at the survey's 2 mounts (0.60 m high pitched +10 deg;
// 0.60 m high pitched -10 deg)".
std::string describeMounts(const UnmappedRegion& r)
{
  char text[96];
  if (r.xtions.size() <= 1)
  {
    std::snprintf(text, sizeof(text), "%.2f m high and pitched %+.0f deg", r.xtion.height_m, r.xtion.pitch_deg);
    return text;
  }
  std::string out = "at the survey's " + std::to_string(r.xtions.size()) + " mounts (";
  for (size_t k = 0; k < r.xtions.size(); ++k)
  {
    std::snprintf(text, sizeof(text), "%s%.2f m high pitched %+.0f deg", k == 0 ? "" : "; ", r.xtions[k].height_m,
                  r.xtions[k].pitch_deg);
    out += text;
  }
  return out + ")";
}

// What to do about a region mostly higher or lower than every mount of the Xtion sees within its reach (a region
// below: its heights are lower bounds, furniture unknown, hence "if").
std::string xtionAdvice(const UnmappedRegion& r)
{
  const bool above = r.xtion_above_share >= r.xtion_below_share;
  const std::string mounts = describeMounts(r);
  char what[448];
  if (above)
    std::snprintf(what, sizeof(what),
                  " (but what it shows reaches at least %.1f m high (the camera hangs at %.1f m), and the Xtion, %s, "
                  "has nothing above %.1f m in view within its depth's reach (%.1f m): ",
                  r.structure_max_height_m, r.camera_height_m, mounts.c_str(), r.xtion.highestInReach(r.xtion_reach_m),
                  r.xtion_reach_m);
  else
    std::snprintf(what, sizeof(what),
                  " (but what it shows reaches down to %.1f m, and the Xtion, %s, has nothing below %.1f m in view "
                  "within its depth's reach (%.1f m): if the region's lines are that low (not on furniture above the "
                  "floor), ",
                  r.structure_min_height_m, mounts.c_str(), r.xtion.lowestInReach(r.xtion_reach_m), r.xtion_reach_m);
  const char* drive = r.xtions.size() > 1 ? " for another drive, keeping the recordings so far, "
                                          : " for a second drive, keeping the first one's recording, ";
  return std::string(what) + xtionRemedy(r, false) + drive + "or calibrate this camera from CAD lines)";
}
}  // namespace

std::string SurveyGuidance::sentence() const
{
  std::string out;
  for (const auto& r : regions)
  {
    char buffer[512];
    std::snprintf(buffer, sizeof(buffer),
                  "survey the %s view: %zu image line%s there ha%s no map line; drive the robot to about "
                  "(%.1f, %.1f) in the map and look towards (%.2f, %.2f)",
                  (r.where == "whole" ? std::string("whole") : r.where + " part of the").c_str(), r.image_lines,
                  r.image_lines == 1 ? "" : "s", r.image_lines == 1 ? "s" : "ve", r.robot_position.x(),
                  r.robot_position.y(), r.look_direction.x(), r.look_direction.y());
    out += (out.empty() ? "" : "; also ") + std::string(buffer);
    if (r.outOfXtionReach(min_xtion_share))
      out += xtionAdvice(r);
  }
  return out;
}

std::vector<Eigen::Vector2d> visitedPositions(const std::vector<Keyframe>& keyframes)
{
  std::vector<Eigen::Vector2d> out;
  for (const Keyframe& k : keyframes)
    if (out.empty() || (out.back() - k.T_map_camera.translation().head<2>()).norm() > 0.25)
      out.push_back(k.T_map_camera.translation().head<2>());
  return out;
}

namespace
{
// A keyframe's Xtion: height above the floor, pitch and half fields of view; nullopt without intrinsics.
std::optional<XtionView> keyframeView(const Keyframe& k, double floor_height_m)
{
  if (k.focal_px <= 0.0 || k.image_width <= 0 || k.image_height <= 0)
    return std::nullopt;
  const double deg = 180.0 / M_PI;
  const Eigen::Vector3d axis = k.T_map_camera.linear().col(2);
  return XtionView{k.T_map_camera.translation().z() - floor_height_m, std::asin(std::clamp(axis.z(), -1.0, 1.0)) * deg,
                   std::atan(0.5 * k.image_height / k.focal_px) * deg,
                   std::atan(0.5 * k.image_width / k.focal_px) * deg};
}

// Mounts differ by more than this in pitch or height; a robot on a level floor keeps its Xtion's within it.
constexpr double kMountPitchGapDeg = 2.0;
constexpr double kMountHeightGapM = 0.05;

// The views split where the sorted values of `key` jump by more than `gap`.
std::vector<std::vector<XtionView>> splitAtGaps(std::vector<XtionView> views, double XtionView::*key, double gap)
{
  std::sort(views.begin(), views.end(), [&](const XtionView& a, const XtionView& b) { return a.*key < b.*key; });
  std::vector<std::vector<XtionView>> groups;
  for (const XtionView& v : views)
  {
    if (groups.empty() || v.*key - groups.back().back().*key > gap)
      groups.emplace_back();
    groups.back().push_back(v);
  }
  return groups;
}

XtionView medianView(const std::vector<XtionView>& views)
{
  std::vector<double> heights, pitches, vertical, horizontal;
  for (const XtionView& v : views)
  {
    heights.push_back(v.height_m);
    pitches.push_back(v.pitch_deg);
    vertical.push_back(v.vertical_half_fov_deg);
    horizontal.push_back(v.horizontal_half_fov_deg);
  }
  return XtionView{middleValue(heights), middleValue(pitches), middleValue(vertical), middleValue(horizontal)};
}
}  // namespace

std::vector<XtionView> xtionViewsOf(const std::vector<Keyframe>& keyframes, double floor_height_m)
{
  std::vector<XtionView> all;
  for (const Keyframe& k : keyframes)
    if (const auto view = keyframeView(k, floor_height_m))
      all.push_back(*view);
  // A mount holds at least a twentieth of the keyframes (and 3): a robot tilted over a threshold for a moment is none.
  const size_t min_keyframes = std::max<size_t>(3, all.size() / 20);
  std::vector<XtionView> mounts;
  for (const auto& by_pitch : splitAtGaps(all, &XtionView::pitch_deg, kMountPitchGapDeg))
    for (const auto& mount : splitAtGaps(by_pitch, &XtionView::height_m, kMountHeightGapM))
      if (mount.size() >= min_keyframes)
        mounts.push_back(medianView(mount));
  if (mounts.empty() && !all.empty())
    mounts.push_back(medianView(all));  // too few keyframes for any mount to count: their medians
  return mounts;
}

std::optional<double> depthLineReach(const std::vector<Keyframe>& keyframes, double max_sigma_m)
{
  constexpr double kFirstBandM = 1.0, kBandM = 0.25;
  std::vector<size_t> lines, precise;
  for (const Keyframe& k : keyframes)
    for (const KeyframeLine& l : k.lines)
    {
      if (!(l.line.sigma_m > 0.0) || !(l.line.range_m >= kFirstBandM) || !(l.line.range_m < 100.0))
        continue;
      const auto band = static_cast<size_t>((l.line.range_m - kFirstBandM) / kBandM);
      if (band >= lines.size())
        lines.resize(band + 1, 0), precise.resize(band + 1, 0);
      ++lines[band];
      precise[band] += l.line.sigma_m <= max_sigma_m ? 1 : 0;
    }
  for (size_t band = 0; band < lines.size(); ++band)
    if (lines[band] >= kMinReachBandLines && 2 * precise[band] < lines[band])
      return kFirstBandM + kBandM * static_cast<double>(band);
  return std::nullopt;
}

SurveyGuidanceOptions surveyGuidanceOptions(const std::vector<Keyframe>& keyframes, double floor_height_m,
                                            double max_sigma_m, SurveyGuidanceOptions options)
{
  options.xtions = xtionViewsOf(keyframes, floor_height_m);
  options.visited = visitedPositions(keyframes);
  if (const auto reach = depthLineReach(keyframes, max_sigma_m))
    options.xtion_reach_m = *reach;
  return options;
}

SurveyGuidance computeSurveyGuidance(const CameraModel& camera, int width, int height,
                                     const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                     const std::vector<Segment3d>& map_lines, double tolerance_px,
                                     const SurveyGuidanceOptions& options)
{
  SurveyGuidance g;
  g.width = width;
  g.height = height;
  g.columns = std::max(1, options.columns);
  g.rows = std::max(1, options.rows);
  g.min_xtion_share = options.min_xtion_share;
  g.cells.assign(static_cast<size_t>(g.columns * g.rows), GuidanceCell::kEmpty);
  if (width <= 0 || height <= 0)
    return g;
  const cv::Mat explained = projectedMapMask(camera, width, height, map_lines, tolerance_px);
  const cv::Mat map_presence = projectedMapMask(camera, width, height, map_lines, 0.0);
  const CellSamples samples = sampleImageLines(image_lines, explained, g, std::max(0.5, options.sample_step_px));
  classifyCells(samples, map_presence, options, &g);
  const std::vector<size_t> lines_per_cell = unexplainedLinesPerCell(samples, options, g.cells.size());
  const FloorBox box = mapExtent(map_lines, options.map_margin_m);
  const RegionPlacer placer{camera, g, box, options, lines_per_cell};
  for (auto& cells : unmappedComponents(g))
    if (auto region = placer.place(std::move(cells)))
      placer.splitForStandpoints(std::move(*region), std::max(1, options.max_region_parts), &g.regions);
  std::stable_sort(g.regions.begin(), g.regions.end(),
                   [](const UnmappedRegion& a, const UnmappedRegion& b) { return a.image_lines > b.image_lines; });
  if (g.regions.size() > options.max_regions)
    g.regions.resize(options.max_regions);
  return g;
}

Expected<SurveyGuidance> guideSurvey(const FixedCamera& camera, const std::vector<Segment3d>& map_lines,
                                     const ImageLineOptions& image_line_options, const SurveyGuidanceOptions& options)
{
  const FixedCameraConfig& config = camera.config();
  if (camera.imageCount() == 0)
    return Error(ErrorCode::kNotEnoughData, "no image has arrived from " + config.image_topic + " yet");
  std::optional<CameraModel> model;
  double tolerance_px = options.tolerance_px;
  // A refused result shows where its matches put the view, unless its focal length or position is absurd (a result
  // of one line matched was 1.5 km above a hall's floor).
  if (camera.lastRefused() && camera.isPlausible(camera.lastRefused()->calibration.camera))
    model = camera.lastRefused()->calibration.camera;
  else if (camera.calibration())
    model = camera.calibration()->camera;
  else if (config.prior)
  {
    model = cameraFromPrior(*config.prior, config.image_width, config.image_height);
    tolerance_px = options.prior_tolerance_width_fraction * config.image_width;
  }
  if (!model)
    return Error(ErrorCode::kInvalidInput, "camera '" + config.name + "' has neither a prior nor a calibration");
  const auto lines = extractImageLines(camera.medianImage(), *model, image_line_options);
  if (!lines)
    return lines.error();
  std::vector<std::vector<Eigen::Vector2d>> polylines;
  for (const auto& l : *lines)
    polylines.push_back(l.points);
  SurveyGuidanceOptions with_height = options;
  if (config.prior && !with_height.camera_height_m)
    with_height.camera_height_m = config.prior->position.z();
  return computeSurveyGuidance(*model, config.image_width, config.image_height, polylines, map_lines, tolerance_px,
                               with_height);
}

std::vector<Eigen::Vector3d> floorTriangles(const UnmappedRegion& region, double height_m)
{
  std::vector<Eigen::Vector3d> out;
  const auto& p = region.floor_polygon;
  for (size_t k = 2; k < p.size(); ++k)
    for (const Eigen::Vector2d& v : {p[0], p[k - 1], p[k]})
      out.emplace_back(v.x(), v.y(), height_m);
  return out;
}

std::string describeRefusal(const Error& error, const SurveyGuidance& guidance)
{
  const std::string sentence = guidance.sentence();
  std::string text = error.describe();
  if (!sentence.empty())
    text += ". What to do: " + sentence;
  // A view too weakly determined that is mapped already, all but an eighth of it: more of the same survey will not
  // help, and "survey more of the view" alone sends the operator back to where the robot has been.
  const size_t covered = guidance.count(GuidanceCell::kCovered);
  const size_t unmapped = guidance.count(GuidanceCell::kUnmapped);
  if (error.code() == ErrorCode::kDegenerate && covered > 0 && 8 * unmapped <= covered + unmapped)
    text += std::string(sentence.empty() ? ". What to do: " : "; but ") +
            "the view is mapped already where it has image lines (" + std::to_string(covered) + " of " +
            std::to_string(covered + unmapped) +
            " cells), so more of the same survey will hardly help: the edges it sees fix the camera too weakly (a "
            "narrow field of view, or edges mostly on one wall or the floor). Survey edges at other depths in its "
            "view (furniture, door frames, or a tall box placed in the middle of the view), or calibrate it from "
            "CAD lines (calibrate_lines)";
  return text;
}

cv::Mat drawSurveyHint(const cv::Mat& image, const SurveyGuidance& g)
{
  cv::Mat canvas;
  if (image.empty())
    canvas = cv::Mat(std::max(1, g.height), std::max(1, g.width), CV_8UC3, cv::Scalar(0, 0, 0));
  else if (image.channels() == 1)
    cv::cvtColor(image, canvas, cv::COLOR_GRAY2BGR);
  else
    canvas = image.clone();
  const cv::Scalar orange(0, 140, 255);  // BGR
  const int thickness = std::max(1, g.width / 640);
  for (size_t c = 0; c < g.cells.size(); ++c)
  {
    const cv::Rect r = g.cellRect(static_cast<int>(c)) & cv::Rect(0, 0, canvas.cols, canvas.rows);
    cv::Mat roi = canvas(r);
    if (g.cells[c] == GuidanceCell::kUnmapped)
    {
      cv::addWeighted(roi, 0.55, cv::Mat(roi.size(), roi.type(), orange), 0.45, 0.0, roi);
      cv::rectangle(canvas, r, orange, thickness);
    }
    else if (g.cells[c] == GuidanceCell::kEmpty)
      roi *= 0.5;
  }
  const double scale = std::max(0.4, g.width / 1600.0);
  const int line_height = static_cast<int>(28 * scale);
  std::vector<std::string> legend{"orange: image lines without map lines (survey there); dark: no lines"};
  for (size_t k = 0; k < g.regions.size(); ++k)
  {
    const UnmappedRegion& region = g.regions[k];
    const cv::Rect first = g.cellRect(region.cells.front());
    cv::putText(canvas, std::to_string(k + 1), {first.x + first.width / 3, first.y + 2 * first.height / 3},
                cv::FONT_HERSHEY_SIMPLEX, 2.0 * scale, cv::Scalar(255, 255, 255), 2 * thickness, cv::LINE_AA);
    char buffer[200];
    std::snprintf(buffer, sizeof(buffer), "%zu: %s, %zu lines: robot to (%.1f, %.1f), look (%.2f, %.2f)%s", k + 1,
                  region.where.c_str(), region.image_lines, region.robot_position.x(), region.robot_position.y(),
                  region.look_direction.x(), region.look_direction.y(),
                  region.outOfXtionReach(g.min_xtion_share)
                      ? ("; Xtion out of reach: " + xtionRemedy(region, true)).c_str()
                      : "");
    legend.emplace_back(buffer);
  }
  const int band = line_height * static_cast<int>(legend.size()) + line_height / 2;
  cv::Mat bottom = canvas(cv::Rect(0, std::max(0, canvas.rows - band), canvas.cols, std::min(band, canvas.rows)));
  bottom *= 0.3;
  for (size_t k = 0; k < legend.size(); ++k)
    cv::putText(canvas, legend[k], {line_height / 2, canvas.rows - band + line_height * static_cast<int>(k + 1)},
                cv::FONT_HERSHEY_SIMPLEX, 0.7 * scale, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return canvas;
}

}  // namespace insitu_calibration
