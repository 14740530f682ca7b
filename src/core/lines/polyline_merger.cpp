#include "insitu_calibration/lines/polyline_merger.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Dense>

namespace insitu_calibration
{
namespace
{
struct Fragment
{
  int index = -1;
  Eigen::Vector2d a, b;                 // undistorted end points
  std::vector<Eigen::Vector2d> points;  // undistorted samples, end points included
  double length = 0.0;
};

// y = c0 + c1 x + c2 x^2 in a frame (origin, e1, e2).
struct Curve
{
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  Eigen::Vector2d e1 = Eigen::Vector2d::UnitX();
  Eigen::Vector2d e2 = Eigen::Vector2d::UnitY();
  double c0 = 0.0, c1 = 0.0, c2 = 0.0;
  double x_min = 0.0, x_max = 0.0;  // extent of the fragments' end points
  double max_residual = 0.0;
  double rms_residual = 0.0;

  Eigen::Vector2d local(const Eigen::Vector2d& p) const { return {(p - origin).dot(e1), (p - origin).dot(e2)}; }
  Eigen::Vector2d global(double x, double y) const { return origin + x * e1 + y * e2; }
  double y(double x) const { return c0 + c1 * x + c2 * x * x; }
  double slope(double x) const { return c1 + 2.0 * c2 * x; }
  // Approximate perpendicular distance of a point to the curve.
  double distance(const Eigen::Vector2d& p) const
  {
    const Eigen::Vector2d l = local(p);
    const double s = slope(l.x());
    return std::abs(l.y() - y(l.x())) / std::sqrt(1.0 + s * s);
  }
};

Curve fitCurve(const std::vector<const Fragment*>& group, bool allow_curvature)
{
  Curve c;
  size_t n = 0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const Fragment* f : group)
    for (const auto& p : f->points)
    {
      mean += p;
      ++n;
    }
  mean /= static_cast<double>(n);
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const Fragment* f : group)
    for (const auto& p : f->points)
      cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  c.origin = mean;
  c.e1 = eig.eigenvectors().col(1);
  // Keep the direction of the longest (first) fragment for a stable order.
  if (c.e1.dot(group.front()->b - group.front()->a) < 0.0)
    c.e1 = -c.e1;
  c.e2 = Eigen::Vector2d(-c.e1.y(), c.e1.x());
  c.x_min = std::numeric_limits<double>::infinity();
  c.x_max = -std::numeric_limits<double>::infinity();
  for (const Fragment* f : group)
    for (const Eigen::Vector2d& p : {f->a, f->b})
    {
      const double x = c.local(p).x();
      c.x_min = std::min(c.x_min, x);
      c.x_max = std::max(c.x_max, x);
    }
  const double scale = std::max(1.0, 0.5 * (c.x_max - c.x_min));
  const int k = allow_curvature ? 3 : 2;
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (const Fragment* f : group)
    for (const auto& p : f->points)
    {
      const Eigen::Vector2d l = c.local(p);
      const double xs = l.x() / scale;
      const Eigen::Vector3d row(1.0, xs, xs * xs);
      ata += row * row.transpose();
      atb += row * l.y();
    }
  Eigen::Vector3d coef = Eigen::Vector3d::Zero();
  coef.head(k) = ata.topLeftCorner(k, k).ldlt().solve(atb.head(k));
  c.c0 = coef(0);
  c.c1 = coef(1) / scale;
  c.c2 = coef(2) / (scale * scale);
  double sum2 = 0.0;
  c.max_residual = 0.0;
  for (const Fragment* f : group)
    for (const auto& p : f->points)
    {
      const double d = c.distance(p);
      sum2 += d * d;
      c.max_residual = std::max(c.max_residual, d);
    }
  c.rms_residual = std::sqrt(sum2 / static_cast<double>(n));
  return c;
}

// The segments as undistorted fragments (sampled every spacing px), longest first; degenerate or unmappable ones
// left out.
std::vector<Fragment> undistortedFragments(const std::vector<Segment2d>& segments, const DivisionModel& distortion,
                                           double spacing)
{
  std::vector<Fragment> fragments;
  fragments.reserve(segments.size());
  for (size_t i = 0; i < segments.size(); ++i)
  {
    const Segment2d& s = segments[i];
    const double length = s.length();
    if (!s.a.allFinite() || !s.b.allFinite() || !(length > 1.0))
      continue;
    Fragment f;
    f.index = static_cast<int>(i);
    const int steps = std::max(1, static_cast<int>(std::ceil(length / spacing)));
    bool ok = true;
    for (int k = 0; k <= steps && ok; ++k)
    {
      const auto u = distortion.undistort(s.a + (s.b - s.a) * (static_cast<double>(k) / steps));
      if (!u || !u->allFinite())
        ok = false;
      else
        f.points.push_back(*u);
    }
    if (!ok)
      continue;
    f.a = f.points.front();
    f.b = f.points.back();
    f.length = (f.b - f.a).norm();
    if (f.length > 1.0)
      fragments.push_back(std::move(f));
  }
  std::sort(fragments.begin(), fragments.end(),
            [](const Fragment& x, const Fragment& y) { return x.length > y.length; });
  return fragments;
}

// Cheap tests of a fragment against the current curve: gap along it, offset and direction, with the bend the group
// may still take over the length the fragment would add (a chord of length X and sagitta s deviates by up to 4 s
// from the tangent at its end, and turns by 8 s / X).
bool mayJoin(const Curve& curve, const Fragment& f, const PolylineMergeOptions& options, double max_angle)
{
  const Eigen::Vector2d la = curve.local(f.a), lb = curve.local(f.b);
  const double x_lo = std::min(la.x(), lb.x()), x_hi = std::max(la.x(), lb.x());
  const double gap = std::max({0.0, x_lo - curve.x_max, curve.x_min - x_hi});
  if (gap > options.max_gap_px)
    return false;
  const double new_extent = std::max(x_hi, curve.x_max) - std::min(x_lo, curve.x_min);
  const double added = new_extent - (curve.x_max - curve.x_min);
  const double offset_limit = 2.0 * options.max_offset_px + 4.0 * options.max_sagitta_ratio * new_extent;
  if (curve.distance(f.a) > offset_limit || curve.distance(f.b) > offset_limit)
    return false;
  const double xm = 0.5 * (la.x() + lb.x());
  const Eigen::Vector2d tangent = (curve.e1 + curve.slope(xm) * curve.e2).normalized();
  const double bend = 8.0 * options.max_sagitta_ratio * added / std::max(1.0, new_extent);
  return std::abs(tangent.dot((f.b - f.a) / f.length)) >= std::cos(max_angle + bend);
}

// The group's curve refitted with the fragment (the last of the group) passes the whole group's tests.
bool acceptsRefit(const Curve& candidate, const Fragment& f, const PolylineMergeOptions& options, double max_angle)
{
  const double chord = candidate.x_max - candidate.x_min;
  const double sagitta = std::abs(candidate.c2) * 0.25 * chord * chord;
  const double xc = 0.5 * (candidate.local(f.a).x() + candidate.local(f.b).x());
  const Eigen::Vector2d refit_tangent = (candidate.e1 + candidate.slope(xc) * candidate.e2).normalized();
  return candidate.max_residual <= options.max_offset_px && sagitta <= options.max_sagitta_ratio * chord &&
         std::abs(refit_tangent.dot((f.b - f.a) / f.length)) >= std::cos(max_angle);
}

// Grows the group of fragments[seed] with every unused fragment that fits its curve, until none does; marks them used.
Curve growGroup(const std::vector<Fragment>& fragments, size_t seed, const PolylineMergeOptions& options,
                std::vector<char>* used, std::vector<const Fragment*>* group)
{
  const double max_angle = options.max_angle_deg * M_PI / 180.0;
  *group = {&fragments[seed]};
  Curve curve = fitCurve(*group, false);
  bool grown = true;
  while (grown)
  {
    grown = false;
    for (size_t c = seed + 1; c < fragments.size(); ++c)
    {
      if ((*used)[c] || !mayJoin(curve, fragments[c], options, max_angle))
        continue;
      group->push_back(&fragments[c]);
      const Curve candidate = fitCurve(*group, true);
      if (acceptsRefit(candidate, fragments[c], options, max_angle))
      {
        curve = candidate;
        (*used)[c] = 1;
        grown = true;
      }
      else
      {
        group->pop_back();
      }
    }
  }
  return curve;
}

// The group's curve as a distorted polyline, with parts short enough that each stays within max_part_sagitta_px of
// the curve; nothing when a point cannot be distorted.
std::optional<ImagePolyline> polylineOf(const Curve& curve, const std::vector<const Fragment*>& group,
                                        const DivisionModel& distortion, const PolylineMergeOptions& options)
{
  const double chord = curve.x_max - curve.x_min;
  ImagePolyline line;
  line.length_px = chord;
  line.rms_residual_px = curve.rms_residual;
  for (const Fragment* f : group)
    line.fragments.push_back(f->index);
  double part_length = std::max(1.0, options.max_part_length_px);
  const double curvature = 2.0 * std::abs(curve.c2);
  if (curvature > 0.0 && options.max_part_sagitta_px > 0.0)
    part_length = std::min(
        part_length, std::max(options.min_part_length_px, std::sqrt(8.0 * options.max_part_sagitta_px / curvature)));
  const int parts = std::max(1, static_cast<int>(std::ceil(chord / part_length)));
  for (int k = 0; k <= parts; ++k)
  {
    const double x = curve.x_min + chord * static_cast<double>(k) / parts;
    const auto d = distortion.distort(curve.global(x, curve.y(x)));
    if (!d || !d->allFinite())
      return std::nullopt;
    line.points.push_back(*d);
  }
  return line;
}
}  // namespace

std::vector<ImagePolyline> mergeSegments(const std::vector<Segment2d>& segments, const DivisionModel& distortion,
                                         const PolylineMergeOptions& options)
{
  const std::vector<Fragment> fragments =
      undistortedFragments(segments, distortion, std::max(1.0, options.sample_spacing_px));
  std::vector<char> used(fragments.size(), 0);
  std::vector<ImagePolyline> out;
  for (size_t seed = 0; seed < fragments.size(); ++seed)
  {
    if (used[seed])
      continue;
    used[seed] = 1;
    std::vector<const Fragment*> group;
    const Curve curve = growGroup(fragments, seed, options, &used, &group);
    if (curve.x_max - curve.x_min < options.min_length_px)
      continue;
    if (auto line = polylineOf(curve, group, distortion, options))
      out.push_back(std::move(*line));
  }
  return out;
}

}  // namespace insitu_calibration
