#include "insitu_calibration/solvers/dlt_system.h"

namespace insitu_calibration
{
void DltSystem::clear()
{
  c11_.setZero();
  c12_.setZero();
  c22_.setZero();
  constraints_ = 0;
}

void DltSystem::addGroup(const Eigen::Matrix4d& world_scatter, const Eigen::Matrix3d& ll, const Eigen::Matrix3d& le,
                         const Eigen::Matrix3d& ee, size_t constraints)
{
  // Kronecker product S (x) L, block (j, k) = S(j, k) L. S is symmetric, so block (k, j) equals block (j, k).
  for (int j = 0; j < 4; ++j)
  {
    for (int k = j; k < 4; ++k)
    {
      const double s = world_scatter(j, k);
      c11_.block<3, 3>(3 * j, 3 * k) += s * ll;
      c12_.block<3, 3>(3 * j, 3 * k) += s * le;
      c22_.block<3, 3>(3 * j, 3 * k) += s * ee;
      if (k != j)
      {
        c11_.block<3, 3>(3 * k, 3 * j) += s * ll;
        c12_.block<3, 3>(3 * k, 3 * j) += s * le;
        c22_.block<3, 3>(3 * k, 3 * j) += s * ee;
      }
    }
  }
  constraints_ += constraints;
}

Matrix12d DltSystem::normalMatrix(double lambda) const
{
  return c11_ + lambda * (c12_ + c12_.transpose()) + (lambda * lambda) * c22_;
}

}  // namespace insitu_calibration
