#include "insitu_calibration/matching/direction_lines.h"

#include <algorithm>
#include <cmath>

namespace insitu_calibration
{
namespace
{
// The main horizontal directions of matched map lines: clusters of azimuths (within 2 deg, mod 180), their
// length-weighted means, most weight first.
struct AzimuthCluster
{
  Eigen::Vector2d doubled = Eigen::Vector2d::Zero();  // sum of length x (cos 2a, sin 2a): directions, not signs
  double weight = 0.0;
  size_t support = 0;
  double azimuth() const { return 0.5 * std::atan2(doubled.y(), doubled.x()); }
};

std::vector<AzimuthCluster> azimuthClusters(std::vector<Segment3d> level)
{
  std::sort(level.begin(), level.end(), [](const Segment3d& a, const Segment3d& b) { return a.length() > b.length(); });
  std::vector<AzimuthCluster> clusters;
  for (const auto& s : level)
  {
    const double a = std::atan2(s.b.y() - s.a.y(), s.b.x() - s.a.x());
    auto near = std::find_if(clusters.begin(), clusters.end(), [&](const AzimuthCluster& c) {
      return std::abs(std::remainder(a - c.azimuth(), M_PI)) < 2.0 * M_PI / 180.0;
    });
    if (near == clusters.end())
      near = clusters.insert(clusters.end(), AzimuthCluster{});
    near->doubled += s.length() * Eigen::Vector2d(std::cos(2.0 * a), std::sin(2.0 * a));
    near->weight += s.length();
    ++near->support;
  }
  std::sort(clusters.begin(), clusters.end(),
            [](const AzimuthCluster& a, const AzimuthCluster& b) { return a.weight > b.weight; });
  return clusters;
}

Eigen::Vector3d horizontal(double azimuth)
{
  return {std::cos(azimuth), std::sin(azimuth), 0.0};
}

// Whether every point of a polyline lies within max_px (undistorted) of the line through the vanishing point of
// direction d under `camera` and the polyline's middle.
bool passesThroughVanishingPoint(const std::vector<Eigen::Vector2d>& polyline, const CameraModel& camera,
                                 const Eigen::Vector3d& d, double max_px)
{
  std::vector<Eigen::Vector3d> u;
  Eigen::Vector3d middle = Eigen::Vector3d::Zero();
  for (const auto& m : polyline)
  {
    const auto x = camera.distortion().undistort(m);
    if (!x)
      return false;
    u.emplace_back(x->x(), x->y(), 1.0);
    middle += u.back() / static_cast<double>(polyline.size());
  }
  const Eigen::Vector3d vanishing = camera.intrinsics().matrix() * camera.pose().rotation * d;
  const Eigen::Vector3d l = vanishing.cross(middle);
  const double norm = l.head<2>().norm();
  return norm > 0.0 &&
         std::all_of(u.begin(), u.end(), [&](const Eigen::Vector3d& x) { return std::abs(l.dot(x)) / norm <= max_px; });
}
}  // namespace

std::vector<DirectionLine> knownDirectionsOf(const std::vector<Segment3d>& matched_map_lines, bool with_horizontal,
                                             size_t min_support)
{
  std::vector<DirectionLine> out = {DirectionLine{{}, Eigen::Vector3d::UnitZ(), -1}};
  if (!with_horizontal)
    return out;
  std::vector<Segment3d> level;
  for (const auto& s : matched_map_lines)
    if (std::abs((s.b - s.a).normalized().z()) < std::sin(3.0 * M_PI / 180.0))
      level.push_back(s);
  std::vector<AzimuthCluster> clusters;
  for (const auto& c : azimuthClusters(level))
    if (c.support >= min_support && clusters.size() < 2)
      clusters.push_back(c);
  if (clusters.size() == 2 &&
      std::abs(std::remainder(clusters[0].azimuth() - clusters[1].azimuth(), M_PI)) > 88.0 * M_PI / 180.0)
  {
    // A rectangular building: one azimuth for both, the weighted mean of the two clusters' modulo 90 deg.
    const double a0 = clusters[0].azimuth();
    const double a1 = a0 + std::remainder(clusters[1].azimuth() + 0.5 * M_PI - a0, M_PI);
    const double a = (clusters[0].weight * a0 + clusters[1].weight * a1) / (clusters[0].weight + clusters[1].weight);
    out.push_back({{}, horizontal(a), 0});
    out.push_back({{}, horizontal(a + 0.5 * M_PI), 0});
    return out;
  }
  for (size_t k = 0; k < clusters.size(); ++k)
    out.push_back({{}, horizontal(clusters[k].azimuth()), static_cast<int>(k)});
  return out;
}

std::vector<DirectionLine> directionLinesOf(const std::vector<LineMatch>& matches,
                                            const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                            const CameraModel& camera, const std::vector<DirectionLine>& directions,
                                            double min_length_px, double max_px, std::vector<bool>* taken)
{
  std::vector<DirectionLine> out;
  taken->assign(image_lines.size(), false);
  if (!(min_length_px > 0.0))
    return out;
  const std::vector<bool> matched = matchedImageLines(matches, image_lines.size());
  for (size_t i = 0; i < image_lines.size(); ++i)
  {
    const auto& l = image_lines[i];
    if (matched[i] || l.size() < 2 || (l.back() - l.front()).norm() < min_length_px)
      continue;
    std::vector<DirectionLine> through;
    for (const auto& d : directions)
      if (passesThroughVanishingPoint(l, camera, d.direction, max_px))
        through.push_back(d);
    if (through.size() != 1)
      continue;
    out.push_back(through.front());
    out.back().image = l;
    (*taken)[i] = true;
  }
  return out;
}

}  // namespace insitu_calibration
