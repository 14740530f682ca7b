#include "insitu_calibration/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace insitu_calibration
{
namespace
{
// Distance to segment [a, b], extended beyond a (extend_start) or b (extend_end) to a ray or a line.
double distanceToPart(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b, bool extend_start,
                      bool extend_end)
{
  const Eigen::Vector2d d = b - a;
  const double length2 = d.squaredNorm();
  if (length2 <= 0.0)
    return (p - a).norm();
  double t = (p - a).dot(d) / length2;
  if (!extend_start)
    t = std::max(t, 0.0);
  if (!extend_end)
    t = std::min(t, 1.0);
  return (p - (a + t * d)).norm();
}
}  // namespace

double distanceToPolyline(const Eigen::Vector2d& point, const std::vector<Eigen::Vector2d>& polyline)
{
  if (polyline.empty())
    return std::numeric_limits<double>::infinity();
  if (polyline.size() == 1)
    return (point - polyline[0]).norm();
  double best = std::numeric_limits<double>::infinity();
  const size_t parts = polyline.size() - 1;
  for (size_t j = 0; j < parts; ++j)
    best = std::min(best, distanceToPart(point, polyline[j], polyline[j + 1], j == 0, j + 1 == parts));
  return best;
}

std::vector<double> lineResiduals(const CameraModel& camera, const LineCorrespondence& line)
{
  std::vector<double> out;
  out.reserve(line.world.size());
  for (const auto& x : line.world)
  {
    const auto m = camera.project(x);
    out.push_back(m ? distanceToPolyline(*m, line.image) : std::numeric_limits<double>::infinity());
  }
  return out;
}

ReprojectionStats summarize(std::vector<double> residuals, size_t unprojectable)
{
  ReprojectionStats s;
  s.unprojectable = unprojectable;
  residuals.erase(std::remove_if(residuals.begin(), residuals.end(),
                                 [&s](double r) {
                                   const bool bad = !std::isfinite(r);
                                   s.unprojectable += bad ? 1 : 0;
                                   return bad;
                                 }),
                  residuals.end());
  s.count = residuals.size();
  if (residuals.empty())
    return s;
  double sum2 = 0.0;
  for (double r : residuals)
  {
    sum2 += r * r;
    s.max_px = std::max(s.max_px, r);
  }
  s.mse_px2 = sum2 / static_cast<double>(residuals.size());
  s.rms_px = std::sqrt(s.mse_px2);
  const size_t mid = residuals.size() / 2;
  std::nth_element(residuals.begin(), residuals.begin() + mid, residuals.end());
  s.median_px = residuals[mid];
  if (residuals.size() % 2 == 0)
    s.median_px = 0.5 * (s.median_px + *std::max_element(residuals.begin(), residuals.begin() + mid));
  return s;
}

ReprojectionStats reprojectionStats(const CameraModel& camera, const CorrespondenceSet& data, bool use_lines,
                                    bool use_points)
{
  std::vector<double> residuals;
  if (use_lines)
    for (const auto& line : data.lines)
    {
      const auto r = lineResiduals(camera, line);
      residuals.insert(residuals.end(), r.begin(), r.end());
    }
  if (use_points)
    for (const auto& p : data.points)
    {
      const auto m = camera.project(p.world);
      residuals.push_back(m ? (*m - p.image).norm() : std::numeric_limits<double>::infinity());
    }
  return summarize(std::move(residuals));
}

double relativeFocalError(const Intrinsics& truth, const Intrinsics& estimate)
{
  return (truth.fx - estimate.fx) / truth.fx;
}

double rotationDistance(const Eigen::Matrix3d& r1, const Eigen::Matrix3d& r2)
{
  // atan2 of the rotation's sine and cosine stays accurate for small angles, where acos((trace - 1) / 2) does not.
  const Eigen::Matrix3d r = r1.transpose() * r2;
  const Eigen::Vector3d axis_sin(r(2, 1) - r(1, 2), r(0, 2) - r(2, 0), r(1, 0) - r(0, 1));
  return std::atan2(0.5 * axis_sin.norm(), 0.5 * (r.trace() - 1.0));
}

double centerDistance(const CameraPose& a, const CameraPose& b)
{
  return (a.center() - b.center()).norm();
}

CameraErrors compareCameras(const CameraModel& truth, const CameraModel& estimate)
{
  CameraErrors e;
  e.focal_relative = relativeFocalError(truth.intrinsics(), estimate.intrinsics());
  e.rotation_rad = rotationDistance(truth.pose().rotation, estimate.pose().rotation);
  e.center_m = centerDistance(truth.pose(), estimate.pose());
  e.principal_point_px = (truth.intrinsics().principalPoint() - estimate.intrinsics().principalPoint()).norm();
  const double dl = std::abs(estimate.distortion().lambda - truth.distortion().lambda);
  e.lambda_relative = truth.distortion().lambda != 0.0 ? dl / std::abs(truth.distortion().lambda) : dl;
  return e;
}

}  // namespace insitu_calibration
