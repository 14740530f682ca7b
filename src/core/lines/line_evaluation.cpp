#include "insitu_calibration/lines/line_evaluation.h"

#include <algorithm>
#include <cmath>

namespace insitu_calibration
{
std::vector<Segment3d> mergeCollinearSegments(const std::vector<Segment3d>& segments, double max_distance_m,
                                              double max_angle_deg)
{
  const size_t n = segments.size();
  std::vector<size_t> parent(n);
  for (size_t i = 0; i < n; ++i)
    parent[i] = i;
  auto root = [&](size_t i) {
    while (parent[i] != i)
      i = parent[i] = parent[parent[i]];
    return i;
  };
  auto onLine = [&](const Segment3d& line, const Eigen::Vector3d& p) {
    const Eigen::Vector3d u = (line.b - line.a).normalized();
    const Eigen::Vector3d r = p - line.a;
    return (r - r.dot(u) * u).norm() <= max_distance_m;
  };
  const double cos_limit = std::cos(max_angle_deg * M_PI / 180.0);
  for (size_t i = 0; i < n; ++i)
  {
    if (!(segments[i].length() > 0.0))
      continue;
    for (size_t j = i + 1; j < n; ++j)
    {
      if (!(segments[j].length() > 0.0))
        continue;
      const Eigen::Vector3d ui = (segments[i].b - segments[i].a).normalized();
      const Eigen::Vector3d uj = (segments[j].b - segments[j].a).normalized();
      if (std::abs(ui.dot(uj)) < cos_limit || !onLine(segments[i], segments[j].a) ||
          !onLine(segments[i], segments[j].b) || !onLine(segments[j], segments[i].a) ||
          !onLine(segments[j], segments[i].b))
        continue;
      parent[root(j)] = root(i);
    }
  }
  std::vector<Segment3d> out;
  std::vector<int> index(n, -1);
  for (size_t i = 0; i < n; ++i)
  {
    const size_t r = root(i);
    if (index[r] < 0)
    {
      index[r] = static_cast<int>(out.size());
      out.push_back(segments[r]);
    }
    // Extend the group's segment along its direction to cover segment i.
    Segment3d& g = out[index[r]];
    const Eigen::Vector3d u = (g.b - g.a).normalized();
    if (!u.allFinite())
      continue;
    double lo = 0.0, hi = (g.b - g.a).dot(u);
    const Eigen::Vector3d origin = g.a;
    for (const Eigen::Vector3d& p : {segments[i].a, segments[i].b})
    {
      const double t = (p - origin).dot(u);
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
    g.a = origin + lo * u;
    g.b = origin + hi * u;
  }
  return out;
}

std::vector<TrueEdgeImage> projectEdges(const CameraModel& camera, const std::vector<Segment3d>& segments,
                                        double near_m)
{
  std::vector<TrueEdgeImage> out;
  const Eigen::Matrix3d k = camera.intrinsics().matrix();
  for (size_t i = 0; i < segments.size(); ++i)
  {
    Eigen::Vector3d a = camera.toCamera(segments[i].a);
    Eigen::Vector3d b = camera.toCamera(segments[i].b);
    if (a.z() < near_m && b.z() < near_m)
      continue;
    if (a.z() < near_m)
      a = b + (a - b) * ((b.z() - near_m) / (b.z() - a.z()));
    if (b.z() < near_m)
      b = a + (b - a) * ((a.z() - near_m) / (a.z() - b.z()));
    const Eigen::Vector3d pa = k * a, pb = k * b;
    TrueEdgeImage e;
    e.edge = static_cast<int>(i);
    e.a = pa.hnormalized();
    e.b = pb.hnormalized();
    if ((e.b - e.a).norm() > 1e-6)
      out.push_back(e);
  }
  return out;
}

std::optional<double> distanceToEdge(const DivisionModel& distortion, const TrueEdgeImage& edge,
                                     const Eigen::Vector2d& pixel, double margin_px)
{
  const auto u = distortion.undistort(pixel);
  if (!u)
    return std::nullopt;
  const Eigen::Vector2d ab = edge.b - edge.a;
  const double len = ab.norm();
  const double s = (*u - edge.a).dot(ab) / len;
  if (s < -margin_px || s > len + margin_px)
    return std::nullopt;
  const auto foot = distortion.distort(edge.a + ab * (s / len));
  if (!foot)
    return std::nullopt;
  return (pixel - *foot).norm();
}

ImageLineError measureImageLine(const std::vector<Eigen::Vector2d>& polyline, const DivisionModel& distortion,
                                const std::vector<TrueEdgeImage>& edges, double max_distance_px, double step_px,
                                double min_coverage)
{
  ImageLineError best;
  if (polyline.size() < 2)
    return best;
  std::vector<Eigen::Vector2d> samples;
  for (size_t i = 0; i + 1 < polyline.size(); ++i)
  {
    const Eigen::Vector2d d = polyline[i + 1] - polyline[i];
    const int steps = std::max(1, static_cast<int>(std::ceil(d.norm() / step_px)));
    for (int k = 0; k < steps; ++k)
      samples.push_back(polyline[i] + d * (static_cast<double>(k) / steps));
  }
  samples.push_back(polyline.back());
  double best_rms = std::numeric_limits<double>::infinity();
  for (const auto& edge : edges)
  {
    // Quick rejection on the end points.
    const auto d0 = distanceToEdge(distortion, edge, polyline.front(), 1e9);
    const auto d1 = distanceToEdge(distortion, edge, polyline.back(), 1e9);
    if (!d0 || !d1 || *d0 > 3.0 * max_distance_px + 5.0 || *d1 > 3.0 * max_distance_px + 5.0)
      continue;
    double sum2 = 0.0, max_d = 0.0;
    int n = 0;
    bool too_far = false;
    for (const auto& p : samples)
    {
      const auto d = distanceToEdge(distortion, edge, p);
      if (!d)
        continue;
      if (*d > max_distance_px)
      {
        too_far = true;
        break;
      }
      sum2 += *d * *d;
      max_d = std::max(max_d, *d);
      ++n;
    }
    if (too_far || n < min_coverage * samples.size() || n == 0)
      continue;
    const double rms = std::sqrt(sum2 / n);
    if (rms < best_rms)
    {
      best_rms = rms;
      best.edge = edge.edge;
      best.rms_px = rms;
      best.max_px = max_d;
      best.samples = n;
    }
  }
  return best;
}

Line3dError measureLine3d(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const std::vector<Segment3d>& truth,
                          double max_distance_m, double max_angle_deg)
{
  Line3dError best;
  const Eigen::Vector3d d = (b - a).normalized();
  double best_distance = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < truth.size(); ++i)
  {
    const Eigen::Vector3d ta = truth[i].a;
    const Eigen::Vector3d td = (truth[i].b - truth[i].a);
    const double tlen = td.norm();
    if (!(tlen > 0.0))
      continue;
    const Eigen::Vector3d tu = td / tlen;
    const double angle = std::acos(std::min(1.0, std::abs(tu.dot(d)))) * 180.0 / M_PI;
    if (angle > max_angle_deg)
      continue;
    auto distance = [&](const Eigen::Vector3d& p) { return ((p - ta) - (p - ta).dot(tu) * tu).norm(); };
    const double da = distance(a), db = distance(b);
    const double rms = std::sqrt(0.5 * (da * da + db * db));
    if (rms > max_distance_m)
      continue;
    const double sa = (a - ta).dot(tu), sb = (b - ta).dot(tu);
    if (std::max(sa, sb) < 0.0 || std::min(sa, sb) > tlen)
      continue;
    if (rms < best_distance)
    {
      best_distance = rms;
      best.edge = static_cast<int>(i);
      best.angle_deg = angle;
      best.distance_m = rms;
    }
  }
  return best;
}

ViewOffset measureViewOffset(const Eigen::Vector3d& sensor, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                             const std::vector<Segment3d>& truth, double max_distance_m, double max_angle_deg)
{
  ViewOffset out;
  const Line3dError matched = measureLine3d(a, b, truth, max_distance_m, max_angle_deg);
  const Eigen::Vector3d m = 0.5 * (a + b);
  const Eigen::Vector3d ray = m - sensor;
  out.range_m = ray.norm();
  if (matched.edge < 0 || !(out.range_m > 0.0))
    return out;
  out.edge = matched.edge;
  const Eigen::Vector3d r = ray / out.range_m, d = (b - a).normalized();
  out.ray_angle_deg = std::acos(std::min(1.0, std::abs(r.dot(d)))) * 180.0 / M_PI;
  const Segment3d& e = truth[matched.edge];
  const Eigen::Vector3d u = (e.b - e.a).normalized();
  const Eigen::Vector3d foot = e.a + (m - e.a).dot(u) * u;
  const Eigen::Vector3d normal = (a - sensor).cross(b - sensor).normalized();
  out.lateral_m = (m - foot).dot(normal);
  // The ray's closest approach to the edge's line: sensor + t r nearest to e.a + s u.
  const Eigen::Vector3d w = sensor - e.a;
  const double ru = r.dot(u), det = 1.0 - ru * ru;
  if (det > 1e-9)
    out.depth_m = out.range_m - (ru * u.dot(w) - r.dot(w)) / det;
  return out;
}

bool segmentHoldsEdge(const Segment3d& edge, double lo, double hi, const Segment3d& line, double max_distance_m)
{
  const Eigen::Vector3d u = (edge.b - edge.a).normalized();
  auto off = [&](const Eigen::Vector3d& p) { return ((p - edge.a) - (p - edge.a).dot(u) * u).norm(); };
  const double sa = (line.a - edge.a).dot(u), sb = (line.b - edge.a).dot(u);
  return off(line.a) <= max_distance_m && off(line.b) <= max_distance_m && std::max(sa, sb) > lo &&
         std::min(sa, sb) < hi;
}

namespace
{
// The part of the edge an image line shows: where its end points' rays pass closest to the edge's line, from edge.a
// towards edge.b (the whole edge when a ray cannot be formed).
std::pair<double, double> shownPart(const CameraModel& camera, const std::vector<Eigen::Vector2d>& polyline,
                                    const Segment3d& edge)
{
  const Eigen::Vector3d u = (edge.b - edge.a).normalized();
  const Eigen::Vector3d centre = camera.pose().center();
  std::vector<double> s;
  for (const Eigen::Vector2d& p : {polyline.front(), polyline.back()})
  {
    const auto ray = camera.backProject(p);
    if (!ray)
      return {0.0, (edge.b - edge.a).norm()};
    const Eigen::Vector3d r = camera.pose().rotation.transpose() * *ray, w = centre - edge.a;
    // Closest points of centre + t r and edge.a + s u.
    const double ru = r.dot(u), det = 1.0 - ru * ru;
    if (std::abs(det) < 1e-12)
      return {0.0, (edge.b - edge.a).norm()};
    s.push_back((u.dot(w) - ru * r.dot(w)) / det);
  }
  return {std::min(s[0], s[1]), std::max(s[0], s[1])};
}

double polylineLength(const std::vector<Eigen::Vector2d>& polyline)
{
  double length = 0.0;
  for (size_t i = 0; i + 1 < polyline.size(); ++i)
    length += (polyline[i + 1] - polyline[i]).norm();
  return length;
}
}  // namespace

MapCoverage measureMapCoverage(const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                               const CameraModel& true_camera, const std::vector<Segment3d>& true_edges,
                               const std::vector<Segment3d>& map_lines, double max_distance_m)
{
  const std::vector<Segment3d> edges = mergeCollinearSegments(true_edges);
  const std::vector<TrueEdgeImage> images = projectEdges(true_camera, edges);
  MapCoverage coverage;
  for (const auto& polyline : image_lines)
  {
    const double length = polylineLength(polyline);
    coverage.total_px += length;
    ++coverage.lines;
    coverage.details.emplace_back();
    coverage.details.back().length_px = length;
    const ImageLineError on = measureImageLine(polyline, true_camera.distortion(), images, 3.0, 1.0, 0.6);
    if (on.edge < 0)
      continue;
    coverage.on_edge_px += length;
    const Segment3d& edge = edges[on.edge];
    const auto [lo, hi] = shownPart(true_camera, polyline, edge);
    const Eigen::Vector3d u = (edge.b - edge.a).normalized();
    const double len = (edge.b - edge.a).norm();
    CoverageLine& detail = coverage.details.back();
    detail.edge = on.edge;
    detail.shown = {edge.a + std::clamp(lo, 0.0, len) * u, edge.a + std::clamp(hi, 0.0, len) * u};
    const bool held = std::any_of(map_lines.begin(), map_lines.end(), [&](const Segment3d& m) {
      return segmentHoldsEdge(edge, lo, hi, m, max_distance_m);
    });
    detail.covered = held;
    if (held)
    {
      coverage.covered_px += length;
      ++coverage.covered_lines;
    }
  }
  return coverage;
}

}  // namespace insitu_calibration
