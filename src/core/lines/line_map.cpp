#include "insitu_calibration/lines/line_map.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

// The nearer side of a depth step pooled over the observations (LineMapOptions::depth_step_sigmas), for the line's
// direction: 0 (left of it), 1 (right), -1 (no step shown). An observation's left side is the line's when their
// directions agree: the image side of an edge is the same surface from every viewpoint in front of it.
int pooledNearerSide(const MapLine& line, const LineMapOptions& o)
{
  if (!(o.depth_step_sigmas > 0.0))
    return -1;
  std::vector<std::pair<double, double>> steps;  // signed for the line's direction, weight
  double sw = 0.0, swx = 0.0;
  for (const auto& obs : line.observations)
  {
    if (obs.depth_step.samples == 0 || !(obs.depth_step.sigma_m > 0.0))
      continue;
    const double sign = (obs.measured_b - obs.measured_a).dot(line.direction) >= 0.0 ? 1.0 : -1.0;
    const double w = 1.0 / (obs.depth_step.sigma_m * obs.depth_step.sigma_m);
    steps.emplace_back(sign * obs.depth_step.left_nearer_by_m, w);
    sw += w;
    swx += w * steps.back().first;
  }
  if (steps.size() < 3)
    return -1;
  const double mean = swx / sw;
  double scatter = 0.0;
  for (const auto& [x, w] : steps)
    scatter += w * (x - mean) * (x - mean);
  // Observations that disagree more than their errors predict (a step seen from some viewpoints only) widen it.
  const double standard_error = std::sqrt(std::max(1.0, scatter / static_cast<double>(steps.size() - 1)) / sw);
  if (!(std::abs(mean) > o.depth_step_sigmas * standard_error && std::abs(mean) >= o.depth_step_min_m))
    return -1;
  return mean > 0.0 ? 0 : 1;
}

// Each observation's end points: the measured line's, or its nearer side's where the pooled evidence shows a step.
void placeObservationsOnNearerSide(const LineMapOptions& o, MapLine* line)
{
  const int near = pooledNearerSide(*line, o);
  for (auto& obs : line->observations)
  {
    obs.a = obs.measured_a;
    obs.b = obs.measured_b;
    if (near < 0)
      continue;
    const bool along = (obs.measured_b - obs.measured_a).dot(line->direction) >= 0.0;
    const int side = along ? near : 1 - near;
    if (obs.side_a[side].allFinite() && obs.side_b[side].allFinite())
    {
      obs.a = obs.side_a[side];
      obs.b = obs.side_b[side];
    }
  }
}

// Gauss-Newton on the line from the observations' end points, each constrained normal to its interpretation plane
// (sigma_lateral) and in it across the line (sigma_depth), starting from the moments' fit. A few iterations: the
// start is within millimetres.
void refitFromObservations(MapLine* line, const LineMapOptions& options)
{
  if (line->observations.empty())
    return;
  placeObservationsOnNearerSide(options, line);
  const double robust_k = options.robust_k;
  Eigen::Vector3d c = line->point, d = line->direction;
  // Graduated Cauchy loss: a few observations are far off across their plane (their 2D edge on another edge).
  const double scales[] = {64.0, 16.0, 8.0, 4.0, 2.0, 1.0, 1.0};
  for (const double scale : scales)
  {
    const double c2 = robust_k * robust_k * scale * scale;
    const Eigen::Vector3d e1 = d.unitOrthogonal(), e2 = d.cross(e1);
    Eigen::Matrix4d h = Eigen::Matrix4d::Zero();
    Eigen::Vector4d g = Eigen::Vector4d::Zero();
    auto add = [&](const Eigen::Vector3d& m, double sigma, double s, const Eigen::Vector3d& q) {
      const double a1 = m.dot(e1) / sigma, a2 = m.dot(e2) / sigma;
      const Eigen::Vector4d j(a1, s * a1, a2, s * a2);
      const double r = m.dot(q) / sigma;
      const double w = robust_k > 0.0 ? 1.0 / (1.0 + r * r / c2) : 1.0;
      h += w * j * j.transpose();
      g += w * j * r;
    };
    for (const auto& o : line->observations)
    {
      const Eigen::Vector3d dir = (o.b - o.a).normalized();
      Eigen::Vector3d m1 = o.normal, m2;
      double sigma1 = o.sigma_lateral;
      if (m1.squaredNorm() > 0.0)
        m2 = m1.cross(dir).normalized();
      else
      {
        m1 = dir.unitOrthogonal();
        m2 = dir.cross(m1);
        sigma1 = o.sigma_depth;
      }
      for (const Eigen::Vector3d& p : {o.a, o.b})
      {
        const double s = (p - c).dot(d);
        const Eigen::Vector3d q = c + s * d - p;
        add(m1, sigma1, s, q);
        add(m2, o.sigma_depth, s, q);
      }
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(h);
    if (!(eig.eigenvalues()(0) > 1e-9 * eig.eigenvalues()(3)))
      return;
    const Eigen::Vector4d delta = -h.ldlt().solve(g);
    if (!delta.allFinite())
      return;
    c += delta(0) * e1 + delta(2) * e2;
    d = (d + delta(1) * e1 + delta(3) * e2).normalized();
  }
  // The point nearest the moments' centroid, so that the extent keeps its meaning.
  const Eigen::Vector3d mean = line->point;
  line->point = c + (mean - c).dot(d) * d;
  line->direction = d;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& p : {line->extreme_lo, line->extreme_hi})
  {
    const double s = (p - line->point).dot(d);
    lo = std::min(lo, s);
    hi = std::max(hi, s);
  }
  line->s_min = lo;
  line->s_max = hi;
}

// Keeps at most max observations, the most precise (smallest sigma_depth).
void trimObservations(int max, MapLine* line)
{
  auto& obs = line->observations;
  if (static_cast<int>(obs.size()) <= max)
    return;
  std::sort(obs.begin(), obs.end(),
            [](const MapObservation& x, const MapObservation& y) { return x.sigma_depth < y.sigma_depth; });
  obs.resize(std::max(0, max));
}

double observationWeight(const Line3d& o, double min_rms)
{
  const double rms = std::max(o.rms_m, min_rms);
  return std::max(1, o.inliers) / (rms * rms);
}

int distinctKeyframes(const MapLine& line)
{
  std::vector<double> stamps;
  for (const auto& o : line.observations)
    stamps.push_back(o.stamp);
  std::sort(stamps.begin(), stamps.end());
  return static_cast<int>(std::unique(stamps.begin(), stamps.end()) - stamps.begin());
}

// The chi-square quantile at 99 % (Wilson-Hilferty), k >= 1 degrees of freedom.
double chiSquare99(double k)
{
  const double z = 2.326, h = 2.0 / (9.0 * k);
  return k * std::pow(1.0 - h + z * std::sqrt(h), 3);
}

// Whether the observations agree with the fitted line within their errors: each end point's offset in its
// interpretation plane, across the line (depth: sigma_depth times fusion_sigma_scale, with the floor). The offsets
// normal to the planes (a fraction of a millimetre) would only dilute the test. Several observations that disagree
// (two edges, keyframes biased differently) fail it.
bool observationsConsistent(const MapLine& line, const LineMapOptions& o)
{
  double chi2 = 0.0;
  int terms = 0;
  const Eigen::Vector3d& d = line.direction;
  for (const auto& obs : line.observations)
    for (const Eigen::Vector3d& p : {obs.a, obs.b})
    {
      const Eigen::Vector3d r = p - line.point;
      const Eigen::Vector3d q = r - r.dot(d) * d;
      const double lateral = obs.normal.squaredNorm() > 0.0 ? q.dot(obs.normal) : 0.0;
      const double sd = std::hypot(o.fusion_sigma_scale * obs.sigma_depth, o.fusion_floor_m);
      chi2 += std::max(0.0, q.squaredNorm() - lateral * lateral) / (sd * sd);
      ++terms;
    }
  const int dof = terms - 2;  // the line's two degrees of freedom in the planes
  return dof >= 1 && chi2 <= chiSquare99(dof);
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
  const bool precise =
      !(options_.max_sigma_m > 0.0 && o.sigma_m > options_.max_sigma_m) &&
      !(options_.max_sigma_angle_deg > 0.0 &&
        std::atan(std::sqrt(2.0) * o.sigma_m / (o.b - o.a).norm()) * 180.0 / M_PI > options_.max_sigma_angle_deg);
  if (precise)
    return merge(o, &lines_);
  // Uncertain (far, short or noisy): pooled for fusion, where only many consistent keyframes make a used line.
  if (options_.max_fusion_sigma_m > 0.0 && o.sigma_m > 0.0 && o.sigma_m <= options_.max_fusion_sigma_m)
    merge(o, &pool_);
  return -1;
}

int LineMap::merge(const Line3d& o, std::vector<MapLine>* lines)
{
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
  for (size_t i = 0; i < lines->size(); ++i)
  {
    double distance = 0.0;
    if ((*lines)[i].source == MapLineSource::kDepth &&
        compatible((*lines)[i], o.a, o.b, limit, normal, lateral_limit, depth_limit, &distance) &&
        distance < best_distance)
    {
      best_distance = distance;
      best = static_cast<int>(i);
    }
  }
  const double w = observationWeight(o, options_.min_rms_m);
  MapObservation kept;
  kept.a = kept.measured_a = o.a;
  kept.b = kept.measured_b = o.b;
  kept.depth_step = o.depth_step;
  kept.side_a = o.side_a;
  kept.side_b = o.side_b;
  kept.normal = normal;
  kept.sigma_lateral = std::max(options_.lateral_floor_m, options_.lateral_sigma_rad * range);
  kept.sigma_depth = std::hypot(o.sigma_m > 0.0 ? o.sigma_m : limit / 3.0, options_.depth_floor_fit_m);
  kept.sigma_systematic = o.sigma_systematic_m;
  kept.stamp = o.stamp;
  if (best < 0)
  {
    MapLine line;
    line.reference = 0.5 * (o.a + o.b);
    line.direction = (o.b - o.a).normalized();
    addSegmentMoments(o.a, o.b, w, &line);
    line.information = 1.0 / (kept.sigma_depth * kept.sigma_depth);
    line.support = 1;
    line.first_stamp = line.last_stamp = o.stamp;
    refit(&line, {o.a, o.b});
    if (options_.max_observations > 0)
      line.observations.push_back(kept);
    refitFromObservations(&line, options_);
    lines->push_back(line);
    return static_cast<int>(lines->size()) - 1;
  }
  MapLine& line = (*lines)[best];
  addSegmentMoments(o.a, o.b, w, &line);
  line.information += 1.0 / (kept.sigma_depth * kept.sigma_depth);
  ++line.support;
  line.first_stamp = std::min(line.first_stamp, o.stamp);
  line.last_stamp = std::max(line.last_stamp, o.stamp);
  refit(&line, {line.extreme_lo, line.extreme_hi, o.a, o.b});
  if (options_.max_observations > 0)
  {
    line.observations.push_back(kept);
    trimObservations(options_.max_observations, &line);
  }
  refitFromObservations(&line, options_);
  return fuseWithOthers(best, lines);
}

void LineMap::insert(const std::vector<Line3d>& observations)
{
  for (const auto& o : observations)
    insert(o);
}

int LineMap::fuseWithOthers(int index, std::vector<MapLine>* lines)
{
  std::vector<MapLine>& all = *lines;
  bool fused = true;
  while (fused)
  {
    fused = false;
    for (size_t j = 0; j < all.size(); ++j)
    {
      if (static_cast<int>(j) == index || all[j].source != MapLineSource::kDepth)
        continue;
      const MapLine& other = all[j];
      double distance = 0.0;
      // Each line's end points against the other line, within the lateral tolerance in every direction (map lines
      // are averages of many observations; depth errors mostly average out).
      const double limit = std::min(options_.max_distance_m, options_.max_lateral_m);
      const Eigen::Vector3d none = Eigen::Vector3d::Zero();
      if (!compatible(all[index], other.a(), other.b(), limit, none, limit, limit, &distance) ||
          !compatible(other, all[index].a(), all[index].b(), limit, none, limit, limit, &distance))
        continue;
      MapLine& line = all[index];
      // The other's moments about this line's reference.
      const Eigen::Vector3d delta = other.reference - line.reference;
      line.sum_wx += other.sum_wx + other.weight * delta;
      line.sum_wxx += other.sum_wxx + other.sum_wx * delta.transpose() + delta * other.sum_wx.transpose() +
                      other.weight * delta * delta.transpose();
      line.weight += other.weight;
      line.support += other.support;
      line.information += other.information;
      line.first_stamp = std::min(line.first_stamp, other.first_stamp);
      line.last_stamp = std::max(line.last_stamp, other.last_stamp);
      refit(&line, {line.extreme_lo, line.extreme_hi, other.extreme_lo, other.extreme_hi});
      line.observations.insert(line.observations.end(), other.observations.begin(), other.observations.end());
      trimObservations(options_.max_observations, &line);
      refitFromObservations(&line, options_);
      // Remove j (swap with the last) and keep track of index.
      const int last = static_cast<int>(all.size()) - 1;
      if (static_cast<int>(j) != last)
        all[j] = all[last];
      all.pop_back();
      if (index == last)
        index = static_cast<int>(j);
      fused = true;
      break;
    }
  }
  return index;
}

bool LineMap::sameEdge(const MapLine& x, const MapLine& y) const
{
  // Within the merge distance along the same edge, either way.
  const Eigen::Vector3d none = Eigen::Vector3d::Zero();
  const double limit = options_.max_distance_m;
  double distance = 0.0;
  return compatible(x, y.a(), y.b(), limit, none, limit, limit, &distance) ||
         compatible(y, x.a(), x.b(), limit, none, limit, limit, &distance);
}

bool LineMap::heldElsewhere(size_t candidate) const
{
  // A precise line holds the edge already; or another pool line from two or more keyframes claims it a little off
  // (depth biased differently from two sides: each group consistent, the groups centimetres apart).
  const MapLine& fused = pool_[candidate];
  for (const auto& line : lines_)
    if (line.source == MapLineSource::kDepth && sameEdge(line, fused))
      return true;
  for (size_t j = 0; j < pool_.size(); ++j)
    if (j != candidate && distinctKeyframes(pool_[j]) >= 2 && sameEdge(pool_[j], fused))
      return true;
  return false;
}

std::vector<MapLine> LineMap::fusedLines(FusionCounts* counts) const
{
  FusionCounts n;
  std::vector<MapLine> out;
  for (size_t i = 0; i < pool_.size(); ++i)
  {
    const MapLine& candidate = pool_[i];
    ++n.pool;
    if (distinctKeyframes(candidate) < std::max(1, options_.min_fusion_keyframes))
      continue;
    ++n.keyframes;
    // What averaging achieves must meet a precise observation's bar; the floor then stands for what it cannot.
    const double sigma = std::hypot(candidate.sigma(), options_.fusion_floor_m);
    const double angle_deg = std::atan(std::sqrt(2.0) * candidate.sigma() / candidate.length()) * 180.0 / M_PI;
    if (!(candidate.sigma() <= options_.max_sigma_m) ||
        (options_.max_sigma_angle_deg > 0.0 && !(angle_deg <= options_.max_sigma_angle_deg)))
      continue;
    ++n.sigma;
    if (!observationsConsistent(candidate, options_))
      continue;
    ++n.consistent;
    if (heldElsewhere(i))
      continue;
    ++n.used;
    out.push_back(candidate);
    out.back().fused = true;
    out.back().information = 1.0 / (sigma * sigma);
  }
  if (counts)
    *counts = n;
  return out;
}

std::vector<MapLine> LineMap::lines(int min_support) const
{
  std::vector<MapLine> out;
  for (const auto& l : lines_)
    if (l.support >= min_support)
      out.push_back(l);
  if (options_.max_fusion_sigma_m > 0.0)
    for (const auto& l : fusedLines())
      if (l.support >= min_support)
        out.push_back(l);
  return out;
}

}  // namespace insitu_calibration
