#include "insitu_calibration/simulation/route_planner.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <utility>

#include "insitu_calibration/io/parameter_range.h"

namespace insitu_calibration
{
namespace simulation
{
namespace
{
double distanceToSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b)
{
  const Eigen::Vector2d d = b - a;
  const double t = d.squaredNorm() > 0.0 ? std::clamp((p - a).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
  return (p - (a + t * d)).norm();
}

// The free cells of the walkable area (clearance from its border and from every obstacle), as a grid.
class Grid
{
public:
  Grid(const FloorPlan& plan, double cell, double clearance)
      : origin_(plan.walkable.min()),
        cell_(cell),
        nx_(std::max(1, static_cast<int>(plan.walkable.sizes().x() / cell))),
        ny_(std::max(1, static_cast<int>(plan.walkable.sizes().y() / cell))),
        free_(nx_ * ny_, 0)
  {
    Eigen::AlignedBox2d inner(plan.walkable.min() + Eigen::Vector2d::Constant(clearance),
                              plan.walkable.max() - Eigen::Vector2d::Constant(clearance));
    for (int j = 0; j < ny_; ++j)
      for (int i = 0; i < nx_; ++i)
      {
        const Eigen::Vector2d p = center(i, j);
        bool ok = !inner.isEmpty() && inner.contains(p);
        for (size_t k = 0; ok && k < plan.obstacles.size(); ++k)
          ok = distanceToFootprint(p, plan.obstacles[k]) > clearance;
        free_[index(i, j)] = ok ? 1 : 0;
      }
  }
  Eigen::Vector2d center(int i, int j) const { return origin_ + cell_ * Eigen::Vector2d(i + 0.5, j + 0.5); }
  int index(int i, int j) const { return j * nx_ + i; }
  bool inside(int i, int j) const { return i >= 0 && j >= 0 && i < nx_ && j < ny_; }
  bool isFree(int i, int j) const { return inside(i, j) && free_[index(i, j)] != 0; }
  bool isFree(const Eigen::Vector2d& p) const
  {
    return isFree(static_cast<int>(std::floor((p.x() - origin_.x()) / cell_)),
                  static_cast<int>(std::floor((p.y() - origin_.y()) / cell_)));
  }
  // Keeps only the largest 4-connected free region.
  void keepLargestRegion()
  {
    std::vector<int> label(free_.size(), -1);
    std::vector<size_t> sizes;
    for (int start = 0; start < static_cast<int>(free_.size()); ++start)
    {
      if (!free_[start] || label[start] >= 0)
        continue;
      const int id = static_cast<int>(sizes.size());
      sizes.push_back(0);
      std::vector<int> stack{start};
      label[start] = id;
      while (!stack.empty())
      {
        const int c = stack.back();
        stack.pop_back();
        ++sizes[id];
        const int i = c % nx_, j = c / nx_;
        for (const auto& [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}})
          if (isFree(i + di, j + dj) && label[index(i + di, j + dj)] < 0)
          {
            label[index(i + di, j + dj)] = id;
            stack.push_back(index(i + di, j + dj));
          }
      }
    }
    const int best = static_cast<int>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
    for (size_t c = 0; c < free_.size(); ++c)
      free_[c] = (label[c] == best) ? 1 : 0;
  }
  // A* on the 8-connected grid (diagonals only between free cells); cell indices from a to b.
  std::vector<int> shortestPath(int a, int b) const
  {
    std::vector<double> cost(free_.size(), std::numeric_limits<double>::infinity());
    std::vector<int> parent(free_.size(), -1);
    using Entry = std::pair<double, int>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
    const auto h = [&](int c) { return (center(c % nx_, c / nx_) - center(b % nx_, b / nx_)).norm(); };
    cost[a] = 0.0;
    open.push({h(a), a});
    while (!open.empty())
    {
      const int c = open.top().second;
      open.pop();
      if (c == b)
        break;
      const int i = c % nx_, j = c / nx_;
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di)
        {
          if ((di == 0 && dj == 0) || !isFree(i + di, j + dj) || !isFree(i + di, j) || !isFree(i, j + dj))
            continue;
          const int n = index(i + di, j + dj);
          const double c2 = cost[c] + cell_ * std::hypot(di, dj);
          if (c2 < cost[n])
          {
            cost[n] = c2;
            parent[n] = c;
            open.push({c2 + h(n), n});
          }
        }
    }
    std::vector<int> path;
    for (int c = b; c >= 0; c = parent[c])
      path.push_back(c);
    std::reverse(path.begin(), path.end());
    return path.front() == a ? path : std::vector<int>{};
  }
  // Whether the straight segment stays on free cells.
  bool lineOfSight(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const
  {
    const int steps = static_cast<int>(std::ceil((b - a).norm() / (0.25 * cell_))) + 1;
    for (int k = 0; k <= steps; ++k)
      if (!isFree(a + (b - a) * (static_cast<double>(k) / steps)))
        return false;
    return true;
  }
  int nx() const { return nx_; }
  int ny() const { return ny_; }
  // The free cell nearest to p within max_distance, or -1.
  int nearestFree(const Eigen::Vector2d& p, double max_distance) const
  {
    int best = -1;
    double best_distance = max_distance;
    for (int j = 0; j < ny_; ++j)
      for (int i = 0; i < nx_; ++i)
        if (free_[index(i, j)] && (center(i, j) - p).norm() <= best_distance)
        {
          best = index(i, j);
          best_distance = (center(i, j) - p).norm();
        }
    return best;
  }

private:
  Eigen::Vector2d origin_;
  double cell_;
  int nx_, ny_;
  std::vector<char> free_;
};

// Lane end points: lanes spread evenly (about `spacing` apart) over the rows that have free cells, per lane its
// first and last free cell, alternating direction (boustrophedon).
std::vector<int> laneTargets(const Grid& grid, bool along_x, double spacing, double cell)
{
  const int lanes_across = along_x ? grid.ny() : grid.nx();
  const int along = along_x ? grid.nx() : grid.ny();
  const auto cellAt = [&](int lane, int k) { return along_x ? std::pair{k, lane} : std::pair{lane, k}; };
  int lo = -1, hi = -1;
  for (int lane = 0; lane < lanes_across; ++lane)
    for (int k = 0; k < along; ++k)
      if (const auto [i, j] = cellAt(lane, k); grid.isFree(i, j))
      {
        lo = lo < 0 ? lane : lo;
        hi = lane;
        break;
      }
  if (lo < 0)
    return {};
  const int n = std::max(1, static_cast<int>(std::lround((hi - lo) * cell / spacing)) + 1);
  std::vector<int> targets;
  bool forward = true;
  for (int l = 0; l < n; ++l)
  {
    const int lane = n == 1 ? (lo + hi) / 2 : lo + static_cast<int>(std::lround((hi - lo) * l / (n - 1.0)));
    int first = -1, last = -1;
    for (int k = 0; k < along; ++k)
      if (const auto [i, j] = cellAt(lane, k); grid.isFree(i, j))
      {
        first = first < 0 ? grid.index(i, j) : first;
        last = grid.index(i, j);
      }
    if (first < 0)
      continue;
    targets.push_back(forward ? first : last);
    if (last != first)
      targets.push_back(forward ? last : first);
    forward = !forward;
  }
  return targets;
}

// Each view leg as its start and end cell: as far along its direction as the floor stays free.
std::vector<int> viewLegTargets(const Grid& grid, const std::vector<ViewLeg>& legs, double cell)
{
  std::vector<int> targets;
  for (const ViewLeg& leg : legs)
  {
    const int start = grid.nearestFree(leg.start, 3.0);
    if (start < 0 || leg.direction.norm() < 1e-9)
      continue;
    const Eigen::Vector2d from = grid.center(start % grid.nx(), start / grid.nx());
    const Eigen::Vector2d d = leg.direction.normalized();
    double length = 0.0;
    while (length + cell <= leg.max_length_m && grid.lineOfSight(from, from + (length + cell) * d))
      length += cell;
    if (length < 0.5)
      continue;
    targets.push_back(start);
    targets.push_back(grid.nearestFree(from + length * d, 3.0 * cell));
  }
  return targets;
}

// The cell path as waypoints: from each point, straight to the farthest later point in line of sight.
std::vector<Eigen::Vector2d> straighten(const Grid& grid, const std::vector<Eigen::Vector2d>& path)
{
  std::vector<Eigen::Vector2d> out{path.front()};
  size_t i = 0;
  while (i + 1 < path.size())
  {
    size_t j = i + 1;
    for (size_t k = path.size() - 1; k > i + 1; --k)
      if (grid.lineOfSight(path[i], path[k]))
      {
        j = k;
        break;
      }
    out.push_back(path[j]);
    i = j;
  }
  return out;
}

// The look-around square at p for a robot arriving along d: to the left if free, else to the right, else none.
std::vector<Eigen::Vector2d> lookAroundSquare(const Grid& grid, const Eigen::Vector2d& p, const Eigen::Vector2d& d,
                                              double side)
{
  for (const double turn : {1.0, -1.0})
  {
    const Eigen::Vector2d v = turn * Eigen::Vector2d(-d.y(), d.x());
    const std::vector<Eigen::Vector2d> square{p + side * d, p + side * (d + v), p + side * v, p};
    bool free = true;
    for (size_t k = 0; free && k < square.size(); ++k)
      free = grid.lineOfSight(k == 0 ? p : square[k - 1], square[k]);
    if (free)
      return square;
  }
  return {};
}

// The route with a look-around every `spacing` metres of driving (the first at half of it), where one fits.
std::vector<Eigen::Vector2d> withLookArounds(const Grid& grid, const std::vector<Eigen::Vector2d>& route,
                                             double spacing, double side)
{
  std::vector<Eigen::Vector2d> out{route.front()};
  double next = 0.5 * spacing, driven = 0.0;
  for (size_t k = 1; k < route.size(); ++k)
  {
    const Eigen::Vector2d a = route[k - 1], b = route[k];
    const double leg = (b - a).norm();
    const Eigen::Vector2d d = (b - a) / std::max(leg, 1e-9);
    // A look-around needs room before the leg's end (the robot turns there anyway) and after its start.
    for (; next < driven + leg - side; next += spacing)
    {
      if (next < driven + side)
        continue;
      const Eigen::Vector2d p = a + (next - driven) * d;
      const std::vector<Eigen::Vector2d> square = lookAroundSquare(grid, p, d, side);
      if (square.empty())
        continue;
      out.push_back(p);
      out.insert(out.end(), square.begin(), square.end());
    }
    driven += leg;
    out.push_back(b);
  }
  return out;
}

// Each leg between consecutive targets on its shortest free path, straightened on its own (a shortcut across targets
// would skip lanes).
std::vector<Eigen::Vector2d> joinTargets(const Grid& grid, const std::vector<int>& targets)
{
  std::vector<Eigen::Vector2d> route;
  for (size_t k = 0; k + 1 < targets.size(); ++k)
  {
    std::vector<Eigen::Vector2d> cells;
    for (const int c : grid.shortestPath(targets[k], targets[k + 1]))
      cells.push_back(grid.center(c % grid.nx(), c / grid.nx()));
    if (cells.empty())
      continue;
    for (const Eigen::Vector2d& p : straighten(grid, cells))
      if (route.empty() || (p - route.back()).norm() > 1e-6)
        route.push_back(p);
  }
  return route;
}

std::vector<Eigen::Vector2d> cutAtLength(const std::vector<Eigen::Vector2d>& points, double max_length)
{
  std::vector<Eigen::Vector2d> out{points.front()};
  double length = 0.0;
  for (size_t k = 1; k < points.size(); ++k)
  {
    const double leg = (points[k] - points[k - 1]).norm();
    if (length + leg > max_length)
    {
      const double rest = max_length - length;
      if (rest > 0.3)
        out.push_back(points[k - 1] + (points[k] - points[k - 1]) * (rest / leg));
      break;
    }
    length += leg;
    out.push_back(points[k]);
  }
  return out;
}

Eigen::Vector2d rotated(const Eigen::Vector2d& d, double deg)
{
  const double a = deg * M_PI / 180.0;
  return {std::cos(a) * d.x() - std::sin(a) * d.y(), std::sin(a) * d.x() + std::cos(a) * d.y()};
}

// The legs a visit drives at its standpoint p, ending facing d: the sweep starting at p, else ending there, else one
// leg along d from p, else one ending at p; the first whose legs all stay free. Empty when none is.
std::vector<Eigen::Vector2d> visitLegs(const Grid& grid, const Eigen::Vector2d& p, const Eigen::Vector2d& d,
                                       const VisitOptions& options)
{
  std::vector<Eigen::Vector2d> sweep{Eigen::Vector2d::Zero()};
  if (options.sweep_deg > 0.0)
    for (const double deg : {options.sweep_deg, -options.sweep_deg})
      sweep.push_back(sweep.back() + options.leg_m * rotated(d, deg));
  sweep.push_back(sweep.back() + options.leg_m * d);
  const std::vector<Eigen::Vector2d> single{Eigen::Vector2d::Zero(), options.leg_m * d};
  for (const std::vector<Eigen::Vector2d>* shape : {&std::as_const(sweep), &single})
    for (const bool ending_at_p : {false, true})
    {
      std::vector<Eigen::Vector2d> legs;
      for (const Eigen::Vector2d& offset : *shape)
        legs.push_back(p + offset - (ending_at_p ? shape->back() : Eigen::Vector2d::Zero()));
      bool free = true;
      for (size_t k = 1; free && k < legs.size(); ++k)
        free = grid.lineOfSight(legs[k - 1], legs[k]);
      if (free)
        return legs;
    }
  return {};
}
}  // namespace

Expected<std::vector<Eigen::Vector2d>> appendVisits(const FloorPlan& plan, std::vector<Eigen::Vector2d> route,
                                                    const std::vector<Visit>& visits, const VisitOptions& options,
                                                    size_t* skipped)
{
  Grid grid(plan, options.cell_m, options.clearance_m);
  grid.keepLargestRegion();
  if (route.empty())
    return Error(ErrorCode::kInvalidInput, "no route to extend by visits");
  int here = grid.nearestFree(route.back(), options.max_offset_m);
  if (here < 0)
    return Error(ErrorCode::kNoSolution, "the route's end has no free cell within " +
                                             formatParameterValue(options.max_offset_m) +
                                             " m to start the visits from");
  size_t left_out = 0;
  std::vector<bool> done(visits.size(), false);
  for (size_t n = 0; n < visits.size(); ++n)
  {
    size_t next = visits.size();
    for (size_t k = 0; k < visits.size(); ++k)
      if (!done[k] && (next == visits.size() ||
                       (visits[k].standpoint - route.back()).norm() < (visits[next].standpoint - route.back()).norm()))
        next = k;
    done[next] = true;
    const Visit& visit = visits[next];
    const int stand = grid.nearestFree(visit.standpoint, options.max_offset_m);
    const std::vector<Eigen::Vector2d> legs = stand < 0 || visit.look_direction.norm() < 1e-9
                                                  ? std::vector<Eigen::Vector2d>{}
                                                  : visitLegs(grid, grid.center(stand % grid.nx(), stand / grid.nx()),
                                                              visit.look_direction.normalized(), options);
    const int start = legs.empty() ? -1 : grid.nearestFree(legs.front(), options.cell_m);
    if (start < 0)
    {
      ++left_out;
      continue;
    }
    // The path's cells end at the legs' start cell; the legs themselves are exact.
    std::vector<Eigen::Vector2d> path = joinTargets(grid, {here, start});
    path.insert(path.end(), legs.begin(), legs.end());
    for (const Eigen::Vector2d& p : path)
      if ((p - route.back()).norm() > 1e-6)
        route.push_back(p);
    here = grid.nearestFree(route.back(), options.max_offset_m);
  }
  if (skipped)
    *skipped = left_out;
  return route;
}

double distanceToFootprint(const Eigen::Vector2d& p, const Footprint& quad)
{
  bool inside = true;
  double sign = 0.0;
  double best = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < 4; ++k)
  {
    const Eigen::Vector2d& a = quad[k];
    const Eigen::Vector2d& b = quad[(k + 1) % 4];
    const Eigen::Vector2d e = b - a, r = p - a;
    const double cross = e.x() * r.y() - e.y() * r.x();
    if (sign == 0.0)
      sign = cross >= 0.0 ? 1.0 : -1.0;
    else if (cross * sign < 0.0)
      inside = false;
    best = std::min(best, distanceToSegment(p, a, b));
  }
  return inside ? 0.0 : best;
}

double polylineLength(const std::vector<Eigen::Vector2d>& points)
{
  double length = 0.0;
  for (size_t k = 1; k < points.size(); ++k)
    length += (points[k] - points[k - 1]).norm();
  return length;
}

Expected<std::vector<Eigen::Vector2d>> planCoverageRoute(const FloorPlan& plan, const RoutePlanOptions& options)
{
  Grid grid(plan, options.cell_m, options.clearance_m);
  grid.keepLargestRegion();
  const bool along_x = plan.walkable.sizes().x() >= plan.walkable.sizes().y();
  const std::vector<int> lanes = laneTargets(grid, along_x, options.lane_spacing_m, options.cell_m);
  if (lanes.size() < 2)
    return Error(ErrorCode::kNoSolution, "the floor has no free lane " + formatParameterValue(options.clearance_m) +
                                             " m clear of walls and obstacles");
  const std::vector<int> legs = viewLegTargets(grid, options.view_legs, options.cell_m);
  std::vector<Eigen::Vector2d> route = joinTargets(grid, legs);
  // Look-arounds on the lanes only: the view legs already face where the cameras look.
  std::vector<Eigen::Vector2d> lane_route = joinTargets(grid, lanes);
  if (options.look_around_spacing_m > 0.0 && lane_route.size() >= 2)
    lane_route = withLookArounds(grid, lane_route, options.look_around_spacing_m, options.look_around_side_m);
  if (!legs.empty())
  {
    // From the last view leg to the lanes' start.
    std::vector<Eigen::Vector2d> transit = joinTargets(grid, {legs.back(), lanes.front()});
    route.insert(route.end(), transit.begin() + (transit.empty() ? 0 : 1), transit.end());
  }
  for (const Eigen::Vector2d& p : lane_route)
    if (route.empty() || (p - route.back()).norm() > 1e-6)
      route.push_back(p);
  if (options.max_length_m > 0.0 && polylineLength(route) > options.max_length_m)
    route = cutAtLength(route, options.max_length_m);
  if (route.size() < 2)
    return Error(ErrorCode::kNoSolution, "the planned route is shorter than one leg");
  return route;
}

}  // namespace simulation
}  // namespace insitu_calibration
