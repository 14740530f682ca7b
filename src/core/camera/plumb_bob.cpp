#include <Eigen/Geometry>

#include "insitu_calibration/camera/plumb_bob.h"

#include <cmath>
#include <vector>

#include <Eigen/Dense>

namespace insitu_calibration
{
Eigen::Vector2d applyPlumbBob(const std::array<double, 5>& c, const Eigen::Vector2d& x)
{
  const double r2 = x.squaredNorm();
  const double radial = 1.0 + r2 * (c[0] + r2 * (c[1] + r2 * c[4]));
  const double xy = x.x() * x.y();
  return {x.x() * radial + 2.0 * c[2] * xy + c[3] * (r2 + 2.0 * x.x() * x.x()),
          x.y() * radial + c[2] * (r2 + 2.0 * x.y() * x.y()) + 2.0 * c[3] * xy};
}

PlumbBobFit fitPlumbBob(const Intrinsics& intrinsics, const DivisionModel& distortion, int image_width,
                        int image_height)
{
  PlumbBobFit fit;
  if (distortion.lambda == 0.0 || image_width <= 1 || image_height <= 1)
    return fit;
  const Eigen::Matrix3d k_inv = intrinsics.matrix().inverse();
  const int nx = 41;
  const int ny = 31;
  std::vector<Eigen::Vector2d> undistorted;
  std::vector<Eigen::Vector2d> distorted;
  for (int iy = 0; iy < ny; ++iy)
    for (int ix = 0; ix < nx; ++ix)
    {
      const Eigen::Vector2d pixel((image_width - 1) * ix / double(nx - 1), (image_height - 1) * iy / double(ny - 1));
      const auto u = distortion.undistort(pixel);
      if (!u)
        continue;
      undistorted.push_back((k_inv * u->homogeneous()).hnormalized());
      distorted.push_back((k_inv * pixel.homogeneous()).hnormalized());
    }
  if (undistorted.size() < 3)
    return fit;
  // x_d - x_u = x_u (k1 r^2 + k2 r^4 + k3 r^6): linear in (k1, k2, k3).
  Eigen::MatrixXd a(2 * undistorted.size(), 3);
  Eigen::VectorXd b(2 * undistorted.size());
  for (size_t i = 0; i < undistorted.size(); ++i)
  {
    const Eigen::Vector2d& x = undistorted[i];
    const double r2 = x.squaredNorm();
    for (int d = 0; d < 2; ++d)
    {
      a.row(2 * i + d) << x(d) * r2, x(d) * r2 * r2, x(d) * r2 * r2 * r2;
      b(2 * i + d) = distorted[i](d) - x(d);
    }
  }
  const Eigen::Vector3d k = a.colPivHouseholderQr().solve(b);
  fit.coefficients = {k(0), k(1), 0.0, 0.0, k(2)};
  double sum2 = 0.0;
  const Eigen::Matrix3d km = intrinsics.matrix();
  for (size_t i = 0; i < undistorted.size(); ++i)
  {
    const Eigen::Vector2d model = (km * applyPlumbBob(fit.coefficients, undistorted[i]).homogeneous()).head<2>();
    const Eigen::Vector2d truth = (km * distorted[i].homogeneous()).head<2>();
    const double e = (model - truth).norm();
    sum2 += e * e;
    fit.max_error_px = std::max(fit.max_error_px, e);
  }
  fit.rms_error_px = std::sqrt(sum2 / undistorted.size());
  return fit;
}

}  // namespace insitu_calibration
