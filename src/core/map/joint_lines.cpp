#include "insitu_calibration/map/joint_lines.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace insitu_calibration
{
std::optional<Eigen::Vector3d> besideSeparation(const Segment3d& a, const Segment3d& b, double cos_max,
                                                double min_overlap)
{
  const double la = a.length(), lb = b.length();
  if (!(la > 1e-9) || !(lb > 1e-9))  // also NaN
    return std::nullopt;
  const Eigen::Vector3d u = (a.b - a.a) / la;
  const Eigen::Vector3d v = (b.b - b.a) / lb;
  if (!(std::abs(u.dot(v)) >= cos_max))
    return std::nullopt;
  const double s0 = (b.a - a.a).dot(u), s1 = (b.b - a.a).dot(u);
  const double lo = std::max(0.0, std::min(s0, s1)), hi = std::min(la, std::max(s0, s1));
  if (hi - lo < min_overlap * std::min(la, lb))
    return std::nullopt;
  const Eigen::Vector3d on_a = a.a + 0.5 * (lo + hi) * u;
  const Eigen::Vector3d on_b = b.a + (on_a - b.a).dot(v) * v;  // b's point beside it
  const Eigen::Vector3d offset = on_b - on_a;
  return Eigen::Vector3d(offset - offset.dot(u) * u);
}

std::vector<bool> textureLines(const std::vector<Segment3d>& lines, const TextureLineOptions& options)
{
  std::vector<bool> texture(lines.size(), false);
  if (options.min_neighbours == 0)
    return texture;
  const double cos_max = std::cos(options.max_angle_deg * M_PI / 180.0);
  const size_t per_side = (options.min_neighbours + 1) / 2;
  for (size_t i = 0; i < lines.size(); ++i)
  {
    std::vector<Eigen::Vector3d> offsets;  // distinct ones
    size_t first_side = 0;                 // the side of offsets[0] (positive dot product with it)
    for (size_t j = 0; j < lines.size(); ++j)
    {
      const auto s = j == i ? std::nullopt : besideSeparation(lines[i], lines[j], cos_max, options.min_overlap);
      if (!s || s->norm() > options.max_spacing_m || s->norm() < options.distinct_m ||
          std::any_of(offsets.begin(), offsets.end(),
                      [&](const Eigen::Vector3d& o) { return (o - *s).norm() < options.distinct_m; }))
        continue;
      offsets.push_back(*s);
      first_side += s->dot(offsets.front()) > 0.0 ? 1 : 0;
    }
    // Inside a texture, not beside its border: enough lines on either side (an edge next to a brick field is not
    // one of its joints).
    texture[i] =
        first_side >= per_side && offsets.size() - first_side >= per_side && offsets.size() >= options.min_neighbours;
  }
  return texture;
}

std::vector<double> unresolvedJointSigmas(const std::vector<Segment3d>& lines, const std::vector<double>& sigmas_m,
                                          const Eigen::Vector3d& viewpoint, double focal_px,
                                          const UnresolvedJointOptions& options)
{
  std::vector<double> out = sigmas_m.empty() ? std::vector<double>(lines.size(), 0.0) : sigmas_m;
  if (!options.enabled || out.size() != lines.size() || !(focal_px > 0.0))
    return sigmas_m;
  const double cos_max = std::cos(options.max_angle_deg * M_PI / 180.0);
  for (size_t i = 0; i < lines.size(); ++i)
  {
    const Eigen::Vector3d ray = lines[i].pointAt(0.5) - viewpoint;
    const double range = ray.norm();
    // Across the line's image: perpendicular to the line and to the viewing ray (none for a line seen end on).
    const Eigen::Vector3d across = (lines[i].b - lines[i].a).cross(ray);
    if (!(range > 1e-6) || !(across.norm() > 1e-9 * range * lines[i].length()))
      continue;
    const Eigen::Vector3d normal = across.normalized();
    double widest = 0.0;  // the unresolved twins' widest separation: the ridge's edge may lie anywhere across it
    for (size_t j = 0; j < lines.size(); ++j)
    {
      const auto s = j == i ? std::nullopt : besideSeparation(lines[i], lines[j], cos_max, options.min_overlap);
      if (!s)
        continue;
      const double width = s->norm();
      if (width > options.max_separation_m || width <= widest)
        continue;
      if (std::abs(s->dot(normal)) * focal_px / range < options.min_resolved_px)  // px across, at this range
        widest = width;
    }
    if (widest > 0.0)
      out[i] = std::hypot(out[i], 0.5 * widest);
  }
  return out;
}
}  // namespace insitu_calibration
