#include "insitu_calibration/solvers/normalization.h"

#include <cmath>

namespace insitu_calibration
{
namespace
{
template <int Dim>
IsotropicNormalization<Dim> computeNormalization(const std::vector<Eigen::Matrix<double, Dim, 1>>& points,
                                                 const std::optional<Eigen::Matrix<double, Dim, 1>>& fixed_origin,
                                                 double target_mean_distance)
{
  using Vector = Eigen::Matrix<double, Dim, 1>;
  IsotropicNormalization<Dim> n;
  if (points.empty())
    return n;
  Vector sum = Vector::Zero();
  for (const auto& p : points)
    sum += p;
  n.origin = fixed_origin ? *fixed_origin : Vector(sum / static_cast<double>(points.size()));
  double distance = 0.0;
  for (const auto& p : points)
    distance += (p - n.origin).norm();
  distance /= static_cast<double>(points.size());
  n.scale = distance > 0.0 ? target_mean_distance / distance : 1.0;
  return n;
}
}  // namespace

ImageNormalization computeImageNormalization(const std::vector<Eigen::Vector2d>& points,
                                             const std::optional<Eigen::Vector2d>& fixed_origin)
{
  return computeNormalization<2>(points, fixed_origin, std::sqrt(2.0));
}

WorldNormalization computeWorldNormalization(const std::vector<Eigen::Vector3d>& points)
{
  return computeNormalization<3>(points, std::nullopt, std::sqrt(3.0));
}

}  // namespace insitu_calibration
