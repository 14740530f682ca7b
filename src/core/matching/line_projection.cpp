#include "matching/line_projection.h"

#include <algorithm>
#include <cmath>

#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/metrics.h"

namespace insitu_calibration
{
namespace matching
{
bool insideImage(const Eigen::Vector2d& m, int width, int height)
{
  return m.x() >= 0.0 && m.y() >= 0.0 && m.x() <= width - 1.0 && m.y() <= height - 1.0;
}

std::vector<ImageChord> summarizeImageLines(const std::vector<std::vector<Eigen::Vector2d>>& image_lines)
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

ProjectedLine projectLine(const CameraModel& camera, const Segment3d& segment, int width, int height, int samples)
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

double angleBetween(const Eigen::Vector2d& a, const Eigen::Vector2d& b)
{
  return std::acos(std::min(1.0, std::abs(a.dot(b)))) / kDegToRad;
}

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

double meanDistance(const ImageChord& image, const ProjectedLine& projected)
{
  double sum = 0.0;
  for (const auto& m : *image.points)
    sum += distanceToPolyline(m, projected.polyline);
  return sum / image.points->size();
}

double chordDistance(const ImageChord& image, const ProjectedLine& projected)
{
  const Eigen::Vector2d normal(-projected.direction.y(), projected.direction.x());
  return (std::abs(normal.dot(image.first - projected.first)) + std::abs(normal.dot(image.mid - projected.first)) +
          std::abs(normal.dot(image.last - projected.first))) /
         3.0;
}
}  // namespace matching

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
    if (m && matching::insideImage(*m, image_width, image_height))
    {
      t0 = std::min(t0, t);
      t1 = std::max(t1, t);
    }
  }
  if (t1 <= t0)
    return std::nullopt;
  return std::make_pair(t0, t1);
}
}  // namespace insitu_calibration
