#include "insitu_calibration/map/triangulated_lines.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <set>

#include <Eigen/Dense>

#include "insitu_calibration/map/floor_lines.h"

namespace insitu_calibration
{
namespace
{
// A keyframe under its corrected pose: camera -> map rotation and centre.
struct View
{
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d C = Eigen::Vector3d::Zero();
  double focal_px = 0.0;
  const std::vector<FloorObservation>* segments = nullptr;
  const DepthRangeGrid* free = nullptr;
};

struct Line
{
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
};

// One keyframe's segment supporting a line.
struct Support
{
  int view = 0;
  int segment = 0;
};

// The unit normal (map frame) of the plane through the camera centre and the segment.
Eigen::Vector3d planeNormal(const View& v, const FloorObservation& s)
{
  return (v.R * Eigen::Vector3d(s.image_a.x(), s.image_a.y(), 1.0))
      .cross(v.R * Eigen::Vector3d(s.image_b.x(), s.image_b.y(), 1.0))
      .normalized();
}

// Where the ray through normalised point p meets the line (closest approach): its depth in the camera (the ray is
// (x, y, 1)) and the position along the line. nullopt when the ray and the line are parallel.
std::optional<std::pair<double, double>> rayOnLine(const View& v, const Eigen::Vector2d& p, const Line& line)
{
  const Eigen::Vector3d r = v.R * Eigen::Vector3d(p.x(), p.y(), 1.0);
  const Eigen::Vector3d w = line.point - v.C;
  const double rr = r.dot(r), rd = r.dot(line.direction), dd = line.direction.dot(line.direction);
  const double det = rd * rd - rr * dd;
  if (std::abs(det) < 1e-12 * rr * dd)
    return std::nullopt;
  // r.(t r - w - s d) = 0 and d.(t r - w - s d) = 0.
  const double t = (-dd * r.dot(w) + rd * line.direction.dot(w)) / det;
  const double s = (rr * line.direction.dot(w) - rd * r.dot(w)) / det;
  return std::make_pair(t, s);
}

// The segment's extent along the line, when both end points' rays meet it within the range limits.
std::optional<std::pair<double, double>> extentOn(const View& v, const FloorObservation& s, const Line& line,
                                                  const TriangulatedLineOptions& o)
{
  const auto a = rayOnLine(v, s.image_a, line), b = rayOnLine(v, s.image_b, line);
  if (!a || !b)
    return std::nullopt;
  for (const double depth : {a->first, b->first})
    if (!(depth >= o.min_range_m && depth <= o.max_range_m))
      return std::nullopt;
  return std::make_pair(std::min(a->second, b->second), std::max(a->second, b->second));
}

// Signed distances (px) of the segment's end points from the line's image.
Eigen::Vector2d imageResiduals(const View& v, const FloorObservation& s, const Line& line)
{
  const Eigen::Vector3d l = (v.R.transpose() * (line.point - v.C)).cross(v.R.transpose() * line.direction);
  const double norm = l.head<2>().norm();
  return v.focal_px / norm *
         Eigen::Vector2d(l.dot(Eigen::Vector3d(s.image_a.x(), s.image_a.y(), 1.0)),
                         l.dot(Eigen::Vector3d(s.image_b.x(), s.image_b.y(), 1.0)));
}

// Whether a segment lies along the line: both end points within max_px of its image, about parallel to it, in
// front within range, overlapping the extent [s_min, s_max].
bool alongLine(const View& v, const FloorObservation& s, const Line& line, double s_min, double s_max, double max_px,
               const TriangulatedLineOptions& o)
{
  const Eigen::Vector2d r = imageResiduals(v, s, line);
  if (!(r.cwiseAbs().maxCoeff() <= max_px))
    return false;
  const double length_px = v.focal_px * (s.image_b - s.image_a).norm();
  if (std::abs(r.x() - r.y()) > length_px * std::sin(o.max_angle_deg * M_PI / 180.0))
    return false;
  const auto extent = extentOn(v, s, line, o);
  return extent && extent->second > s_min && extent->first < s_max;
}

// A supporting segment: along the line within confirm_px.
bool supports(const View& v, const FloorObservation& s, const Line& line, double s_min, double s_max,
              const TriangulatedLineOptions& o)
{
  return alongLine(v, s, line, s_min, s_max, o.confirm_px, o);
}

// Whether two or more other segments of the view lie beside the line's image: along it within repetition_px, not
// within confirm_px (repeated parallel edges; one neighbour alone is a frame's other side, a door's or a skirting's).
bool amongParallels(const View& v, int own_segment, const Line& line, double s_min, double s_max,
                    const TriangulatedLineOptions& o)
{
  int neighbours = 0;
  for (size_t k = 0; k < v.segments->size() && neighbours < 2; ++k)
  {
    const FloorObservation& s = (*v.segments)[k];
    if (static_cast<int>(k) != own_segment && !supports(v, s, line, s_min, s_max, o) &&
        alongLine(v, s, line, s_min, s_max, o.repetition_px, o))
      ++neighbours;
  }
  return neighbours >= 2;
}

// The one segment of a view that supports the line, -1 when none or several do.
int supportingSegment(const View& v, const Line& line, double s_min, double s_max, const std::vector<bool>& used,
                      const TriangulatedLineOptions& o)
{
  int best = -1, supporting = 0;
  double best_px = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < v.segments->size(); ++k)
  {
    if (!supports(v, (*v.segments)[k], line, s_min, s_max, o))
      continue;
    ++supporting;
    if (used[k])
      continue;
    const double px = imageResiduals(v, (*v.segments)[k], line).cwiseAbs().maxCoeff();
    if (px < best_px)
    {
      best_px = px;
      best = static_cast<int>(k);
    }
  }
  // Two segments along it (parallel edges a few px apart in the image: tiles, stripes far away) are ambiguous: the
  // wrong one makes a ghost line that such repeated edges confirm in other views too.
  return supporting == 1 ? best : -1;
}

// The candidate of two segments: the intersection of their planes, with the overlap of their extents.
std::optional<std::pair<Line, std::pair<double, double>>> intersect(const View& v1, const FloorObservation& s1,
                                                                    const View& v2, const FloorObservation& s2,
                                                                    const TriangulatedLineOptions& o)
{
  const Eigen::Vector3d n1 = planeNormal(v1, s1), n2 = planeNormal(v2, s2);
  const Eigen::Vector3d d = n1.cross(n2);
  if (!(d.norm() >= std::sin(o.min_plane_angle_deg * M_PI / 180.0)))
    return std::nullopt;
  Line line;
  line.direction = d.normalized();
  Eigen::Matrix3d A;
  A << n1.transpose(), n2.transpose(), line.direction.transpose();
  line.point = A.colPivHouseholderQr().solve(Eigen::Vector3d(n1.dot(v1.C), n2.dot(v2.C), line.direction.dot(v1.C)));
  const auto e1 = extentOn(v1, s1, line, o), e2 = extentOn(v2, s2, line, o);
  if (!e1 || !e2)
    return std::nullopt;
  const double lo = std::max(e1->first, e2->first), hi = std::min(e1->second, e2->second);
  if (hi - lo < o.min_length_m)
    return std::nullopt;
  return std::make_pair(line, std::make_pair(lo, hi));
}

// The line moved by x: (x0, x1) shift its point along u, w (across it), (x2, x3) turn its direction towards them.
Line perturbed(const Line& line, const Eigen::Vector3d& u, const Eigen::Vector3d& w, const Eigen::Vector4d& x)
{
  return {line.point + x[0] * u + x[1] * w, (line.direction + x[2] * u + x[3] * w).normalized()};
}

// The supporting segments' end-point residuals in units of the pixel noise.
Eigen::VectorXd whitenedResiduals(const std::vector<View>& views, const std::vector<Support>& support, const Line& line,
                                  double pixel_sigma_px)
{
  Eigen::VectorXd r(2 * support.size());
  for (size_t k = 0; k < support.size(); ++k)
  {
    const View& v = views[support[k].view];
    r.segment<2>(2 * k) = imageResiduals(v, (*v.segments)[support[k].segment], line) / pixel_sigma_px;
  }
  return r;
}

// The residuals' Jacobian in the line's four parameters (central differences; the problem is tiny).
Eigen::MatrixXd jacobian(const std::vector<View>& views, const std::vector<Support>& support, const Line& line,
                         const Eigen::Vector3d& u, const Eigen::Vector3d& w, double pixel_sigma_px)
{
  Eigen::MatrixXd J(2 * support.size(), 4);
  const double eps = 1e-6;
  for (int p = 0; p < 4; ++p)
  {
    const Eigen::Vector4d dx = Eigen::Vector4d::Unit(p) * eps;
    J.col(p) = (whitenedResiduals(views, support, perturbed(line, u, w, dx), pixel_sigma_px) -
                whitenedResiduals(views, support, perturbed(line, u, w, -dx), pixel_sigma_px)) /
               (2.0 * eps);
  }
  return J;
}

// Two unit vectors across the direction.
std::pair<Eigen::Vector3d, Eigen::Vector3d> acrossBasis(const Eigen::Vector3d& direction)
{
  const Eigen::Vector3d u = direction.unitOrthogonal();
  return {u, direction.cross(u)};
}

// Gauss-Newton over the line's four parameters; false when the normal equations are singular.
bool refine(const std::vector<View>& views, const std::vector<Support>& support, Line* line, double pixel_sigma_px)
{
  for (int iteration = 0; iteration < 20; ++iteration)
  {
    const auto [u, w] = acrossBasis(line->direction);
    const Eigen::VectorXd r = whitenedResiduals(views, support, *line, pixel_sigma_px);
    const Eigen::MatrixXd J = jacobian(views, support, *line, u, w, pixel_sigma_px);
    const Eigen::LDLT<Eigen::Matrix4d> normal(J.transpose() * J);
    if (normal.info() != Eigen::Success || !(normal.vectorD().minCoeff() > 0.0))
      return false;
    const Eigen::Vector4d dx = normal.solve(-J.transpose() * r);
    if (!dx.allFinite())
      return false;
    *line = perturbed(*line, u, w, dx);
    if (dx.norm() < 1e-13)
      break;
  }
  return true;
}

// The union of the supporting segments' extents; false when one of them no longer meets the line in range.
bool supportedExtent(const std::vector<View>& views, const std::vector<Support>& support, const Line& line,
                     const TriangulatedLineOptions& o, double* s_min, double* s_max)
{
  *s_min = std::numeric_limits<double>::infinity();
  *s_max = -*s_min;
  for (const auto& k : support)
  {
    const auto extent = extentOn(views[k.view], (*views[k.view].segments)[k.segment], line, o);
    if (!extent)
      return false;
    *s_min = std::min(*s_min, extent->first);
    *s_max = std::max(*s_max, extent->second);
  }
  return true;
}

// The predicted error (m) across the line at its worse end point: the least-squares covariance at the pixel noise
// (or at the residuals' level when higher), and the poses' errors (a shift, and a turn over the mean range) in
// quadrature.
double predictedSigma(const std::vector<View>& views, const std::vector<Support>& support, const Line& centred,
                      double half_length, const TriangulatedLineOptions& o)
{
  const auto [u, w] = acrossBasis(centred.direction);
  const Eigen::MatrixXd J = jacobian(views, support, centred, u, w, o.pixel_sigma_px);
  // Scaled by the fit's variance factor when its residuals exceed the pixel noise (segments of nearby edges among
  // the support, noise above the assumed): the prediction must not be more confident than the fit.
  const Eigen::VectorXd r = whitenedResiduals(views, support, centred, o.pixel_sigma_px);
  const double dof = std::max<double>(1.0, static_cast<double>(r.size()) - 4.0);
  const Eigen::Matrix4d covariance = (J.transpose() * J).inverse() * std::max(1.0, r.squaredNorm() / dof);
  double fit = 0.0;
  for (const double s : {-half_length, half_length})
  {
    Eigen::Matrix<double, 2, 4> M;
    M << 1, 0, s, 0, 0, 1, 0, s;
    const Eigen::Matrix2d end = M * covariance * M.transpose();
    fit = std::max(fit, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(end).eigenvalues().maxCoeff());
  }
  double range = 0.0;
  for (const auto& k : support)
    range += (views[k.view].C - centred.point).norm() / static_cast<double>(support.size());
  const double turn = range * o.pose_sigma_deg * M_PI / 180.0;
  return std::sqrt(fit + o.pose_sigma_m * o.pose_sigma_m + turn * turn);
}
}  // namespace
}  // namespace insitu_calibration

namespace insitu_calibration
{
namespace
{
std::vector<View> viewsOf(const std::vector<Keyframe>& keyframes, const std::vector<PoseCorrection>& corrections)
{
  std::vector<View> views;
  for (size_t k = 0; k < keyframes.size(); ++k)
  {
    const Eigen::Isometry3d pose = corrections.size() == keyframes.size()
                                       ? corrections[k].apply(keyframes[k].T_map_camera)
                                       : keyframes[k].T_map_camera;
    views.push_back(
        {pose.linear(), pose.translation(), keyframes[k].focal_px, &keyframes[k].rgb, &keyframes[k].depth_grid});
  }
  return views;
}

// The pair's candidate supported by a keyframe between them (the third view that two views cannot fake).
bool confirmedBetween(const std::vector<View>& views, int i, int j, const Line& line, double lo, double hi,
                      const std::vector<std::vector<bool>>& used, const TriangulatedLineOptions& o)
{
  for (int k = i + 1; k < j; ++k)
    if (supportingSegment(views[k], line, lo, hi, used[k], o) >= 0)
      return true;
  return false;
}

// Per keyframe from `span` before the pair to `span` after it, its best supporting segment (the pair's own two).
std::vector<Support> gatherSupport(const std::vector<View>& views, Support first, Support second, const Line& line,
                                   double lo, double hi, int span, const std::vector<std::vector<bool>>& used,
                                   const TriangulatedLineOptions& o)
{
  std::vector<Support> support;
  const int begin = std::max(0, first.view - span), end = std::min<int>(views.size() - 1, second.view + span);
  for (int k = begin; k <= end; ++k)
  {
    if (k == first.view || k == second.view)
    {
      support.push_back(k == first.view ? first : second);
      continue;
    }
    const int segment = supportingSegment(views[k], line, lo, hi, used[k], o);
    if (segment >= 0)
      support.push_back({k, segment});
  }
  return support;
}

// Whether the line's image lies among repeated parallel edges in at least half of its supporting keyframes.
bool amongRepeatedEdges(const std::vector<View>& views, const std::vector<Support>& support, const Line& line,
                        double s_min, double s_max, const TriangulatedLineOptions& o)
{
  if (!(o.repetition_px > o.confirm_px))
    return false;
  size_t beside = 0;
  for (const auto& k : support)
    beside += amongParallels(views[k.view], k.segment, line, s_min, s_max, o) ? 1 : 0;
  return 2 * beside >= support.size();
}

bool underFloor(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const TriangulatedLineOptions& o)
{
  return std::min(a.z(), b.z()) < o.floor_height_m - o.below_floor_m;
}

// Whether the view's depth saw through the point: nearer than free_max_range_m, and the nearest depth in its part of
// the image farther than it by the margin.
bool sawThrough(const View& v, const Eigen::Vector3d& point, const TriangulatedLineOptions& o)
{
  const Eigen::Vector3d c = v.R.transpose() * (point - v.C);
  if (!v.free || !(c.z() > 0.0 && c.z() <= o.free_max_range_m))
    return false;
  const double nearest = v.free->nearestAt(c.head<2>() / c.z());
  return nearest > c.z() + o.free_margin_m + o.free_margin_per_m2 * c.z() * c.z();
}

// Whether the view's depth hides the point: every depth in its part of the image nearer than the point by the margin
// (something stood in front of it).
bool hides(const View& v, const Eigen::Vector3d& point, const TriangulatedLineOptions& o)
{
  const Eigen::Vector3d c = v.R.transpose() * (point - v.C);
  if (!v.free || !(c.z() > 0.0))
    return false;
  const double farthest = v.free->farthestAt(c.head<2>() / c.z());
  return farthest > 0.0 && farthest < c.z() - o.free_margin_m - o.free_margin_per_m2 * farthest * farthest;
}

// Whether at least a third of the line's points (every 0.1 m from a to b) are ones the predicate holds for.
template <typename Predicate>
bool aThirdOfItsPoints(const Eigen::Vector3d& a, const Eigen::Vector3d& b, Predicate holds)
{
  const int n = std::max(2, static_cast<int>(std::ceil((b - a).norm() / 0.1)) + 1);
  int count = 0;
  for (int i = 0; i < n; ++i)
    count += holds(a + (b - a) * (static_cast<double>(i) / (n - 1))) ? 1 : 0;
  return 3 * count >= n;
}

// Whether the keyframes that support the line had a third or more of its points hidden behind what their depth
// measured.
bool hiddenFromSupport(const std::vector<View>& views, const std::vector<Support>& support, const Eigen::Vector3d& a,
                       const Eigen::Vector3d& b, const TriangulatedLineOptions& o)
{
  return aThirdOfItsPoints(a, b, [&](const Eigen::Vector3d& p) {
    return std::any_of(support.begin(), support.end(), [&](const Support& k) { return hides(views[k.view], p, o); });
  });
}

// Whether some keyframe's depth saw through a third or more of the line's points.
bool inFreeSpace(const std::vector<View>& views, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                 const TriangulatedLineOptions& o)
{
  return aThirdOfItsPoints(a, b, [&](const Eigen::Vector3d& p) {
    return std::any_of(views.begin(), views.end(), [&](const View& v) { return sawThrough(v, p, o); });
  });
}

// The refined line of the support (outliers of the refined line dropped and refined again), centred on its extent,
// as a map line with its predicted error; nullopt when it fails a test.
std::optional<MapLine> fitLine(const std::vector<View>& views, const std::vector<Keyframe>& keyframes,
                               std::vector<Support>* support, Line line, const TriangulatedLineOptions& o)
{
  for (int pass = 0; pass < 2; ++pass)
  {
    if (static_cast<int>(support->size()) < std::max(3, o.min_keyframes) ||
        !refine(views, *support, &line, o.pixel_sigma_px))
      return std::nullopt;
    const Eigen::VectorXd r = whitenedResiduals(views, *support, line, 1.0);
    std::vector<Support> kept;
    for (size_t k = 0; k < support->size(); ++k)
      if (r.segment<2>(2 * k).cwiseAbs().maxCoeff() <= o.confirm_px)
        kept.push_back((*support)[k]);
    if (kept.size() == support->size())
      break;
    *support = kept;
  }
  double s_min = 0.0, s_max = 0.0;
  if (static_cast<int>(support->size()) < std::max(3, o.min_keyframes) ||
      !supportedExtent(views, *support, line, o, &s_min, &s_max) || s_max - s_min < o.min_length_m)
    return std::nullopt;
  const Eigen::Vector3d a = line.point + s_min * line.direction, b = line.point + s_max * line.direction;
  if (amongRepeatedEdges(views, *support, line, s_min, s_max, o) || underFloor(a, b, o) ||
      inFreeSpace(views, a, b, o) || hiddenFromSupport(views, *support, a, b, o))
    return std::nullopt;
  MapLine out;
  out.source = MapLineSource::kTriangulated;
  out.direction = line.direction;
  out.point = line.point + 0.5 * (s_min + s_max) * line.direction;
  out.s_min = -0.5 * (s_max - s_min);
  out.s_max = -out.s_min;
  const double sigma = predictedSigma(views, *support, {out.point, out.direction}, out.s_max, o);
  if (!(sigma <= o.max_sigma_m))
    return std::nullopt;
  out.information = 1.0 / (sigma * sigma);
  out.support = static_cast<int>(support->size());
  out.reference = out.point;
  out.extreme_lo = out.a();
  out.extreme_hi = out.b();
  out.first_stamp = keyframes[support->front().view].stamp;
  out.last_stamp = keyframes[support->back().view].stamp;
  return out;
}

// The map line of a pair of segments: their candidate, confirmed by a keyframe between them, refined on the
// support it gathers, which is gathered again along the refined line (the pair alone places it poorly) and fitted.
std::optional<MapLine> lineOfPair(const std::vector<View>& views, const std::vector<Keyframe>& keyframes, Support first,
                                  Support second, int span, const std::vector<std::vector<bool>>& used,
                                  const TriangulatedLineOptions& o, std::vector<Support>* support)
{
  const auto candidate = intersect(views[first.view], (*views[first.view].segments)[first.segment], views[second.view],
                                   (*views[second.view].segments)[second.segment], o);
  if (!candidate)
    return std::nullopt;
  Line line = candidate->first;
  const auto [lo, hi] = candidate->second;
  if (!confirmedBetween(views, first.view, second.view, line, lo, hi, used, o))
    return std::nullopt;
  *support = gatherSupport(views, first, second, line, lo, hi, span, used, o);
  if (static_cast<int>(support->size()) < std::max(3, o.min_keyframes) ||
      !refine(views, *support, &line, o.pixel_sigma_px))
    return std::nullopt;
  *support = gatherSupport(views, first, second, line, lo, hi, span, used, o);
  return fitLine(views, keyframes, support, line, o);
}
}  // namespace

std::vector<MapLine> triangulateLines(const std::vector<Keyframe>& keyframes,
                                      const std::vector<PoseCorrection>& corrections,
                                      const std::vector<MapLine>& map_lines, const TriangulatedLineOptions& o)
{
  std::vector<MapLine> out;
  if (!o.enabled || o.pair_spans.empty())
    return out;
  const std::vector<View> views = viewsOf(keyframes, corrections);
  std::vector<std::vector<bool>> used;
  for (const auto& v : views)
    used.emplace_back(v.segments->size(), false);
  const int widest = *std::max_element(o.pair_spans.begin(), o.pair_spans.end());
  for (int i = 0; i < static_cast<int>(views.size()); ++i)
    for (const int span : o.pair_spans)
    {
      const int j = i + span;
      if (span < 2 || j >= static_cast<int>(views.size()))
        continue;
      for (int si = 0; si < static_cast<int>(views[i].segments->size()); ++si)
        for (int sj = 0; sj < static_cast<int>(views[j].segments->size()) && !used[i][si]; ++sj)
        {
          if (used[j][sj])
            continue;
          std::vector<Support> support;
          const auto fitted = lineOfPair(views, keyframes, {i, si}, {j, sj}, widest, used, o, &support);
          if (!fitted)
            continue;
          // Its segments are explained either way: by a line of the map, by one triangulated before, or by it.
          for (const auto& k : support)
            used[k.view][k.segment] = true;
          if (!heldByMapLine(*fitted, map_lines, o.max_angle_deg) && !heldByMapLine(*fitted, out, o.max_angle_deg))
            out.push_back(*fitted);
        }
    }
  return out;
}

}  // namespace insitu_calibration
