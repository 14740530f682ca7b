#include "insitu_calibration/solvers/plumb_line.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

namespace insitu_calibration
{
namespace
{
Eigen::Vector2d undistortAbout(const Eigen::Vector2d& m, const Eigen::Vector2d& center, double lambda)
{
  const Eigen::Vector2d rel = m - center;
  return center + rel / (1.0 + lambda * rel.squaredNorm());
}

// Total-least-squares line of points: centroid and unit normal; `scatter` receives the sum of squared distances.
void fitLine(const std::vector<Eigen::Vector2d>& points, Eigen::Vector2d* centroid, Eigen::Vector2d* normal,
             double* scatter)
{
  *centroid = Eigen::Vector2d::Zero();
  for (const auto& x : points)
    *centroid += x / static_cast<double>(points.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const auto& x : points)
    cov += (x - *centroid) * (x - *centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  *normal = eig.eigenvectors().col(0);
  *scatter = std::max(0.0, eig.eigenvalues()(0));
}

// Sum over the polylines of the squared distances of their points to their own straight line after undistortion,
// in distorted px (each polyline's undistorted scatter times its mean local scale 1 + lambda r^2, squared).
double straightnessCost(const std::vector<const std::vector<Eigen::Vector2d>*>& polylines,
                        const Eigen::Vector2d& center, double lambda)
{
  double cost = 0.0;
  std::vector<Eigen::Vector2d> u;
  for (const auto* polyline : polylines)
  {
    u.clear();
    double scale = 0.0;
    for (const auto& m : *polyline)
    {
      const double s = 1.0 + lambda * (m - center).squaredNorm();
      if (!(s > 0.0))
        return std::numeric_limits<double>::infinity();
      scale += s / static_cast<double>(polyline->size());
      u.push_back(undistortAbout(m, center, lambda));
    }
    Eigen::Vector2d centroid, normal;
    double scatter = 0.0;
    fitLine(u, &centroid, &normal, &scatter);
    cost += scatter * scale * scale;
  }
  return cost;
}
}  // namespace

Expected<PlumbLineEstimate> estimatePlumbLineLambda(const std::vector<std::vector<Eigen::Vector2d>>& polylines,
                                                    const Eigen::Vector2d& center, int image_width, int image_height)
{
  std::vector<const std::vector<Eigen::Vector2d>*> curved;
  size_t dof = 0;
  for (const auto& polyline : polylines)
    if (polyline.size() >= 3)
    {
      curved.push_back(&polyline);
      dof += polyline.size() - 2;
    }
  if (curved.size() < 2)
    return Error(ErrorCode::kNotEnoughData,
                 "the plumb-line estimate of lambda needs two or more polylines of 3 or "
                 "more image points");
  double r2 = 0.0;
  for (double x : {0.0, image_width - 1.0})
    for (double y : {0.0, image_height - 1.0})
      r2 = std::max(r2, (Eigen::Vector2d(x, y) - center).squaredNorm());
  // k = lambda r_corner^2 on a grid over the one-to-one range (|k| < 0.8, as the DLT requires), then golden section
  // in the best cell's neighbourhood.
  const double step = 0.01;
  double best_k = 0.0;
  double best_cost = std::numeric_limits<double>::infinity();
  for (double k = -0.7; k <= 0.7 + 1e-9; k += step)
  {
    const double c = straightnessCost(curved, center, k / r2);
    if (c < best_cost)
    {
      best_cost = c;
      best_k = k;
    }
  }
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  double lo = best_k - step, hi = best_k + step;
  for (int i = 0; i < 40; ++i)
  {
    const double a = hi - golden * (hi - lo);
    const double b = lo + golden * (hi - lo);
    if (straightnessCost(curved, center, a / r2) < straightnessCost(curved, center, b / r2))
      hi = b;
    else
      lo = a;
  }
  PlumbLineEstimate out;
  out.center = center;
  out.lambda = 0.5 * (lo + hi) / r2;
  out.polylines = curved.size();
  out.image_sigma_px = std::sqrt(straightnessCost(curved, center, out.lambda) / static_cast<double>(dof));
  return out;
}

std::vector<Eigen::Vector2d> straightenPolyline(const std::vector<Eigen::Vector2d>& polyline,
                                                const DivisionModel& distortion)
{
  std::vector<Eigen::Vector2d> u;
  for (const auto& m : polyline)
    u.push_back(undistortAbout(m, distortion.center, distortion.lambda));
  if (u.size() < 3)
    return u;
  Eigen::Vector2d centroid, normal;
  double scatter = 0.0;
  fitLine(u, &centroid, &normal, &scatter);
  const auto onto = [&](const Eigen::Vector2d& x) -> Eigen::Vector2d { return x - normal * normal.dot(x - centroid); };
  return {onto(u.front()), onto(u.back())};
}

CorrespondenceSet straightenCorrespondences(const CorrespondenceSet& data, const DivisionModel& distortion)
{
  CorrespondenceSet straight = data;
  straight.straight_lines.clear();
  for (auto& line : straight.lines)
    line.image = straightenPolyline(line.image, distortion);
  for (auto& point : straight.points)
    point.image = undistortAbout(point.image, distortion.center, distortion.lambda);
  return straight;
}

Expected<PlumbLineEstimate> estimatePlumbLineLambda(const CorrespondenceSet& data, const Eigen::Vector2d& center)
{
  std::vector<std::vector<Eigen::Vector2d>> polylines;
  for (const auto& line : data.lines)
    polylines.push_back(line.image);
  return estimatePlumbLineLambda(polylines, center, data.image_width, data.image_height);
}

Expected<DltResult> solvePlumbLineDlt(const CorrespondenceSet& data, const DltOptions& options)
{
  const Eigen::Vector2d center = options.distortion_center.value_or(data.imageCenter());
  DivisionModel distortion{0.0, center};
  if (options.estimate_distortion)
  {
    const auto estimate = estimatePlumbLineLambda(data, center);
    if (!estimate)
      return estimate.error();
    distortion.lambda = estimate->lambda;
  }
  const CorrespondenceSet straight = straightenCorrespondences(data, distortion);
  DltOptions pinhole = options;
  pinhole.estimate_distortion = false;
  auto solved = solveDlt(straight, pinhole);
  if (!solved)
    return solved.error();
  solved->camera.distortion() = distortion;
  solved->distortion_estimated = options.estimate_distortion;
  solved->constraints = straight.lineConstraintCount() + 2 * straight.points.size();
  return solved;
}

}  // namespace insitu_calibration
