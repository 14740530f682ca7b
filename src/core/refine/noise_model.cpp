#include "insitu_calibration/refine/noise_model.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace insitu_calibration
{
namespace
{
// Sum of squared distances of points to their least-squares line: the smallest eigenvalues of their scatter.
template <int Dim>
double lineScatter(const std::vector<Eigen::Matrix<double, Dim, 1>>& points)
{
  using Vector = Eigen::Matrix<double, Dim, 1>;
  using Matrix = Eigen::Matrix<double, Dim, Dim>;
  Vector mean = Vector::Zero();
  for (const auto& x : points)
    mean += x / static_cast<double>(points.size());
  Matrix cov = Matrix::Zero();
  for (const auto& x : points)
    cov += (x - mean) * (x - mean).transpose();
  const Vector values = Eigen::SelfAdjointEigenSolver<Matrix>(cov).eigenvalues();
  return std::max(0.0, values.sum() - values(Dim - 1));
}
}  // namespace

NoiseLevels estimateNoiseLevels(const CorrespondenceSet& data, const DivisionModel& distortion, double given_image_px,
                                double given_world_m)
{
  NoiseLevels out;
  double image_sum = 0.0, world_sum = 0.0;
  size_t image_dof = 0, world_dof = 0;
  for (const auto& line : data.lines)
  {
    if (line.image.size() >= 3)
    {
      // Undistorted, then back in distorted px by the polyline's mean local scale.
      std::vector<Eigen::Vector2d> u;
      double scale = 0.0;
      for (const auto& m : line.image)
      {
        const Eigen::Vector2d rel = m - distortion.center;
        const double s = 1.0 + distortion.lambda * rel.squaredNorm();
        scale += s / static_cast<double>(line.image.size());
        u.push_back(rel / s);
      }
      image_sum += lineScatter<2>(u) * scale * scale;
      image_dof += line.image.size() - 2;
    }
    if (line.world.size() >= 3)
    {
      world_sum += lineScatter<3>(line.world);
      world_dof += 2 * (line.world.size() - 2);
    }
  }
  if (given_image_px > 0.0)
    out.image_sigma_px = given_image_px;
  else if (image_dof > 0 && image_sum > 0.0)
  {
    out.image_sigma_px = std::sqrt(image_sum / image_dof);
    out.image_estimated = true;
  }
  if (given_world_m >= 0.0)
    out.world_sigma_m = given_world_m;
  else if (world_dof > 0)
  {
    out.world_sigma_m = std::sqrt(world_sum / world_dof);
    out.world_estimated = true;
  }
  return out;
}

FittedLine3d fitWorldLine(const std::vector<Eigen::Vector3d>& points)
{
  FittedLine3d out;
  if (points.empty())
    return out;
  out.a = points.front();
  out.b = points.back();
  if (points.size() < 3)
    return out;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& x : points)
    mean += x / static_cast<double>(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& x : points)
    cov += (x - mean) * (x - mean).transpose();
  const Eigen::Vector3d direction = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(2);
  out.a = mean + direction * direction.dot(points.front() - mean);
  out.b = mean + direction * direction.dot(points.back() - mean);
  return out;
}

}  // namespace insitu_calibration
