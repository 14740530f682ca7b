// Hartley normalisation: similarity transforms that bring 2D and 3D data to the origin and to a mean distance of
// sqrt(2) (2D) and sqrt(3) (3D), so the DLT's linear system is well conditioned (Hartley, "In defense of the
// eight-point algorithm", 1997).
#ifndef INSITU_CALIBRATION_SOLVERS_NORMALIZATION_H
#define INSITU_CALIBRATION_SOLVERS_NORMALIZATION_H

#include <optional>
#include <vector>

#include <Eigen/Core>

namespace insitu_calibration
{
// x_normalised = scale * (x - origin), as a homogeneous matrix by matrix().
template <int Dim>
struct IsotropicNormalization
{
  using Vector = Eigen::Matrix<double, Dim, 1>;
  using Matrix = Eigen::Matrix<double, Dim + 1, Dim + 1>;

  Vector origin = Vector::Zero();
  double scale = 1.0;

  Vector apply(const Vector& x) const { return scale * (x - origin); }
  Matrix matrix() const
  {
    Matrix m = Matrix::Identity();
    m.template topLeftCorner<Dim, Dim>() *= scale;
    m.template topRightCorner<Dim, 1>() = -scale * origin;
    return m;
  }
  Matrix inverseMatrix() const
  {
    Matrix m = Matrix::Identity();
    m.template topLeftCorner<Dim, Dim>() /= scale;
    m.template topRightCorner<Dim, 1>() = origin;
    return m;
  }
};

using ImageNormalization = IsotropicNormalization<2>;
using WorldNormalization = IsotropicNormalization<3>;

// Centroid and mean distance sqrt(2). With fixed_origin (the distortion centre, which the division model is
// defined around and which a translation would break) only the scale is computed. The division model's lambda
// becomes lambda / scale^2 in normalised coordinates.
ImageNormalization computeImageNormalization(const std::vector<Eigen::Vector2d>& points,
                                             const std::optional<Eigen::Vector2d>& fixed_origin = std::nullopt);
// Centroid and mean distance sqrt(3).
WorldNormalization computeWorldNormalization(const std::vector<Eigen::Vector3d>& points);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_NORMALIZATION_H
