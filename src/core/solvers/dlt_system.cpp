#include "insitu_calibration/solvers/dlt_system.h"

#include <algorithm>

namespace insitu_calibration
{
namespace
{
// (j, k) with j <= k of the symmetric 4x4 scatter, in packing order.
constexpr int kScatterRow[10] = {0, 0, 0, 0, 1, 1, 1, 2, 2, 3};
constexpr int kScatterCol[10] = {0, 1, 2, 3, 1, 2, 3, 2, 3, 3};
}  // namespace

void DltSystem::clear()
{
  packed_.setZero();
  batched_ = 0;
  constraints_ = 0;
  unpacked_ = false;
}

void DltSystem::addGroup(const Eigen::Matrix4d& world_scatter, const Eigen::Matrix3d& ll, const Eigen::Matrix3d& le,
                         const Eigen::Matrix3d& ee, size_t constraints)
{
  double s[10];
  for (int b = 0; b < 10; ++b)
    s[b] = world_scatter(kScatterRow[b], kScatterCol[b]);
  const double l11[9] = {ll(0, 0), ll(0, 1), ll(0, 2), ll(1, 0), ll(1, 1), ll(1, 2), ll(2, 0), ll(2, 1), ll(2, 2)};
  const double l12[6] = {le(0, 0), le(0, 1), le(1, 0), le(1, 1), le(2, 0), le(2, 1)};
  const double l22[3] = {ee(0, 0), ee(0, 1), ee(1, 1)};
  addPackedGroup(s, l11, l12, l22, constraints);
}

void DltSystem::addPackedGroup(const double s[10], const double l11[9], const double l12[6], const double l22[3],
                               size_t constraints)
{
  std::copy(s, s + 10, batch_scatter_.col(batched_).data());
  double* g = batch_image_.col(batched_).data();
  std::copy(l11, l11 + 9, g);
  std::copy(l12, l12 + 6, g + 9);
  std::copy(l22, l22 + 3, g + 15);
  if (++batched_ == kBatch)
    flush();
  constraints_ += constraints;
  unpacked_ = false;
}

void DltSystem::flush() const
{
  if (batched_ == kBatch)
    packed_.noalias() += batch_scatter_ * batch_image_.transpose();
  else if (batched_ > 0)  // a few groups (RANSAC's minimal sets): no GEMM set-up
    packed_.noalias() += batch_scatter_.leftCols(batched_).lazyProduct(batch_image_.leftCols(batched_).transpose());
  batched_ = 0;
}

void DltSystem::unpack() const
{
  if (unpacked_)
    return;
  flush();
  c11_.setZero();
  c12_.setZero();
  c22_.setZero();
  // Kronecker product S (x) L, block (j, k) = S(j, k) L; S is symmetric, so block (k, j) equals block (j, k).
  for (int b = 0; b < 10; ++b)
  {
    const auto p = packed_.row(b);
    Eigen::Matrix3d b11;
    b11 << p(0), p(1), p(2), p(3), p(4), p(5), p(6), p(7), p(8);
    Eigen::Matrix3d b12 = Eigen::Matrix3d::Zero();
    b12.leftCols<2>() << p(9), p(10), p(11), p(12), p(13), p(14);
    Eigen::Matrix3d b22 = Eigen::Matrix3d::Zero();
    b22.topLeftCorner<2, 2>() << p(15), p(16), p(16), p(17);
    const int j = kScatterRow[b];
    const int k = kScatterCol[b];
    c11_.block<3, 3>(3 * j, 3 * k) = b11;
    c12_.block<3, 3>(3 * j, 3 * k) = b12;
    c22_.block<3, 3>(3 * j, 3 * k) = b22;
    c11_.block<3, 3>(3 * k, 3 * j) = b11;
    c12_.block<3, 3>(3 * k, 3 * j) = b12;
    c22_.block<3, 3>(3 * k, 3 * j) = b22;
  }
  unpacked_ = true;
}

const Matrix12d& DltSystem::c11() const
{
  unpack();
  return c11_;
}

const Matrix12d& DltSystem::c12() const
{
  unpack();
  return c12_;
}

const Matrix12d& DltSystem::c22() const
{
  unpack();
  return c22_;
}

Matrix12d DltSystem::normalMatrix(double lambda) const
{
  unpack();
  return c11_ + lambda * (c12_ + c12_.transpose()) + (lambda * lambda) * c22_;
}

}  // namespace insitu_calibration
