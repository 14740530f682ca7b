#include "insitu_calibration/lines/line_map.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace insitu_calibration
{
namespace
{
// Moments of a uniform distribution on the segment a-b, times w.
void addSegmentMoments(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double w, MapLine* line)
{
  const Eigen::Vector3d m = 0.5 * (a + b) - line->reference;
  const Eigen::Vector3d d = b - a;
  line->sum_wx += w * m;
  line->sum_wxx += w * (m * m.transpose() + d * d.transpose() / 12.0);
  line->weight += w;
}

// Point, direction and extent from the moments and the extreme points.
void refit(MapLine* line, const std::vector<Eigen::Vector3d>& extremes)
{
  const Eigen::Vector3d local_mean = line->sum_wx / line->weight;
  const Eigen::Matrix3d cov = line->sum_wxx / line->weight - local_mean * local_mean.transpose();
  const Eigen::Vector3d mean = line->reference + local_mean;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3d dir = eig.eigenvectors().col(2).normalized();
  if (dir.dot(line->direction) < 0.0)
    dir = -dir;
  line->point = mean;
  line->direction = dir;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& p : extremes)
  {
    const double s = (p - mean).dot(dir);
    if (s < lo)
    {
      lo = s;
      line->extreme_lo = p;
    }
    if (s > hi)
    {
      hi = s;
      line->extreme_hi = p;
    }
  }
  line->s_min = lo;
  line->s_max = hi;
}

double observationWeight(const Line3d& o, double min_rms)
{
  const double rms = std::max(o.rms_m, min_rms);
  return std::max(1, o.inliers) / (rms * rms);
}

}  // namespace

std::vector<Eigen::Vector3d> MapLine::samplePoints(int n) const
{
  std::vector<Eigen::Vector3d> out;
  n = std::max(2, n);
  for (int i = 0; i < n; ++i)
    out.push_back(a() + (b() - a()) * (static_cast<double>(i) / (n - 1)));
  return out;
}

double MapLine::spread() const
{
  if (!(weight > 0.0))
    return 0.0;
  const Eigen::Vector3d mean = sum_wx / weight;
  const Eigen::Matrix3d cov = sum_wxx / weight - mean * mean.transpose();
  const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - direction * direction.transpose();
  return std::sqrt(std::max(0.0, (across * cov * across).trace()));
}

LineMap::LineMap(const LineMapOptions& options) : options_(options) {}

bool LineMap::compatible(const MapLine& line, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double limit_m,
                         const Eigen::Vector3d& lateral_normal, double lateral_limit_m, double depth_limit_m,
                         double* distance) const
{
  const Eigen::Vector3d d = b - a;
  const double len = d.norm();
  if (!(len > 0.0))
    return false;
  if (std::abs(d.dot(line.direction)) / len < std::cos(options_.max_angle_deg * M_PI / 180.0))
    return false;
  auto offset = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d r = p - line.point;
    return Eigen::Vector3d(r - r.dot(line.direction) * line.direction);
  };
  const Eigen::Vector3d oa = offset(a), ob = offset(b);
  const double da = oa.norm(), db = ob.norm();
  if (da > limit_m || db > limit_m)
    return false;
  const double la = oa.dot(lateral_normal), lb = ob.dot(lateral_normal);
  if (std::abs(la) > lateral_limit_m || std::abs(lb) > lateral_limit_m)
    return false;
  if (lateral_normal.squaredNorm() > 0.0 && (std::sqrt(std::max(0.0, da * da - la * la)) > depth_limit_m ||
                                             std::sqrt(std::max(0.0, db * db - lb * lb)) > depth_limit_m))
    return false;
  const double sa = (a - line.point).dot(line.direction), sb = (b - line.point).dot(line.direction);
  const double gap = std::max({0.0, std::min(sa, sb) - line.s_max, line.s_min - std::max(sa, sb)});
  if (gap > options_.max_gap_m)
    return false;
  *distance = std::max(da, db);
  return true;
}

int LineMap::insert(const Line3d& o)
{
  if (!o.a.allFinite() || !o.b.allFinite() || !((o.b - o.a).norm() > 0.0))
    return -1;
  if (options_.max_sigma_m > 0.0 && o.sigma_m > options_.max_sigma_m)
    return -1;
  if (options_.max_sigma_angle_deg > 0.0 &&
      std::atan(std::sqrt(2.0) * o.sigma_m / (o.b - o.a).norm()) * 180.0 / M_PI > options_.max_sigma_angle_deg)
    return -1;
  const double range = std::max(0.0, o.range_m);
  const double limit = options_.max_distance_m + options_.max_distance_per_m * range;
  // The normal of the interpretation plane (sensor, a, b), when the sensor is known and not on the line.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  if (o.sensor.allFinite())
  {
    const Eigen::Vector3d n = (o.a - o.sensor).cross(o.b - o.sensor);
    if (n.norm() > 1e-9 * (o.a - o.sensor).norm() * (o.b - o.sensor).norm())
      normal = n.normalized();
  }
  const double lateral_limit = options_.max_lateral_m + options_.max_lateral_per_m * range;
  const double depth_limit =
      o.sigma_m > 0.0 ? options_.depth_sigmas * std::hypot(o.sigma_m, options_.depth_floor_m) : limit;
  int best = -1;
  double best_distance = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < lines_.size(); ++i)
  {
    double distance = 0.0;
    if (compatible(lines_[i], o.a, o.b, limit, normal, lateral_limit, depth_limit, &distance) &&
        distance < best_distance)
    {
      best_distance = distance;
      best = static_cast<int>(i);
    }
  }
  const double w = observationWeight(o, options_.min_rms_m);
  if (best < 0)
  {
    MapLine line;
    line.reference = 0.5 * (o.a + o.b);
    line.direction = (o.b - o.a).normalized();
    addSegmentMoments(o.a, o.b, w, &line);
    line.support = 1;
    line.first_stamp = line.last_stamp = o.stamp;
    refit(&line, {o.a, o.b});
    lines_.push_back(line);
    return static_cast<int>(lines_.size()) - 1;
  }
  MapLine& line = lines_[best];
  addSegmentMoments(o.a, o.b, w, &line);
  ++line.support;
  line.first_stamp = std::min(line.first_stamp, o.stamp);
  line.last_stamp = std::max(line.last_stamp, o.stamp);
  refit(&line, {line.extreme_lo, line.extreme_hi, o.a, o.b});
  return fuseWithOthers(best);
}

void LineMap::insert(const std::vector<Line3d>& observations)
{
  for (const auto& o : observations)
    insert(o);
}

int LineMap::fuseWithOthers(int index)
{
  bool fused = true;
  while (fused)
  {
    fused = false;
    for (size_t j = 0; j < lines_.size(); ++j)
    {
      if (static_cast<int>(j) == index)
        continue;
      const MapLine& other = lines_[j];
      double distance = 0.0;
      // Each line's end points against the other line, within the lateral tolerance in every direction (map lines
      // are averages of many observations; depth errors mostly average out).
      const double limit = std::min(options_.max_distance_m, options_.max_lateral_m);
      const Eigen::Vector3d none = Eigen::Vector3d::Zero();
      if (!compatible(lines_[index], other.a(), other.b(), limit, none, limit, limit, &distance) ||
          !compatible(other, lines_[index].a(), lines_[index].b(), limit, none, limit, limit, &distance))
        continue;
      MapLine& line = lines_[index];
      // The other's moments about this line's reference.
      const Eigen::Vector3d delta = other.reference - line.reference;
      line.sum_wx += other.sum_wx + other.weight * delta;
      line.sum_wxx += other.sum_wxx + other.sum_wx * delta.transpose() + delta * other.sum_wx.transpose() +
                      other.weight * delta * delta.transpose();
      line.weight += other.weight;
      line.support += other.support;
      line.first_stamp = std::min(line.first_stamp, other.first_stamp);
      line.last_stamp = std::max(line.last_stamp, other.last_stamp);
      refit(&line, {line.extreme_lo, line.extreme_hi, other.extreme_lo, other.extreme_hi});
      // Remove j (swap with the last) and keep track of index.
      const int last = static_cast<int>(lines_.size()) - 1;
      if (static_cast<int>(j) != last)
        lines_[j] = lines_[last];
      lines_.pop_back();
      if (index == last)
        index = static_cast<int>(j);
      fused = true;
      break;
    }
  }
  return index;
}

std::vector<MapLine> LineMap::lines(int min_support) const
{
  std::vector<MapLine> out;
  for (const auto& l : lines_)
    if (l.support >= min_support)
      out.push_back(l);
  return out;
}

}  // namespace insitu_calibration
