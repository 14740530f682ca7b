// Shared helpers of the core unit tests.
#ifndef INSITU_CALIBRATION_TEST_SUPPORT_TEST_HELPERS_H
#define INSITU_CALIBRATION_TEST_SUPPORT_TEST_HELPERS_H

#include <cmath>

#include "insitu_calibration/camera/camera_model.h"

namespace insitu_calibration
{
namespace test
{
// Relative difference of two projection matrices up to scale and sign.
inline double projectionDifference(const Matrix34d& a, const Matrix34d& b)
{
  const Matrix34d na = a / a.norm();
  const Matrix34d nb = b / b.norm();
  return std::min((na - nb).norm(), (na + nb).norm());
}

// |lambda_a - lambda_b| relative to |lambda_b|, or scaled by r^2 at the image corner when lambda_b = 0 (the
// displacement fraction the difference makes there).
inline double lambdaDifference(double a, double b, double corner_radius_px)
{
  if (b != 0.0)
    return std::abs(a - b) / std::abs(b);
  return std::abs(a - b) * corner_radius_px * corner_radius_px;
}

}  // namespace test
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_TEST_SUPPORT_TEST_HELPERS_H
