// The linear system of the DLT with division-model distortion, (B1 + lambda B2) vec(P) = 0, kept as the three 12x12
// matrices C11 = B1^T B1, C12 = B1^T B2 and C22 = B2^T B2 rather than as N x 12 rows.
//
// Every constraint has the form l(lambda)^T P M = 0 with l(lambda) = l + lambda e (an image line for DLT-Lines, a row
// of [m]_x for DLT-Points), so its row is M^T (x) l^T and its contribution to C11 is (M M^T) (x) (l l^T). All 3D
// points of a line pair with all parts of its image, so a line's contribution is (sum_k M_k M_k^T) (x) (sum_j l_j
// l_j^T): the cost is linear in points + parts, not in their product. vec() is column-major: p[3 * col + row].
#ifndef INSITU_CALIBRATION_SOLVERS_DLT_SYSTEM_H
#define INSITU_CALIBRATION_SOLVERS_DLT_SYSTEM_H

#include <cstddef>

#include <Eigen/Core>

namespace insitu_calibration
{
using Matrix12d = Eigen::Matrix<double, 12, 12>;
using Vector12d = Eigen::Matrix<double, 12, 1>;

class DltSystem
{
public:
  DltSystem() { clear(); }

  void clear();

  // Adds the constraints (each world point) x (each image row) of one group: world_scatter = sum_k M_k M_k^T over
  // its homogeneous world points, and the sums over its image rows of l l^T, l e^T and e e^T. Every e has a zero
  // third entry (the division model changes only the third coordinate of a homogeneous point), which the packed
  // accumulation relies on.
  void addGroup(const Eigen::Matrix4d& world_scatter, const Eigen::Matrix3d& ll, const Eigen::Matrix3d& le,
                const Eigen::Matrix3d& ee, size_t constraints);
  // The same with the distinct entries only (the hot path of DLT-Lines): scatter (j <= k) in the order 00 01 02 03
  // 11 12 13 22 23 33; ll row-major; le's first two columns row-major (l0e0 l0e1 l1e0 l1e1 l2e0 l2e1); ee as e0e0
  // e0e1 e1e1.
  void addPackedGroup(const double scatter[10], const double ll[9], const double le[6], const double ee[3],
                      size_t constraints);

  // Normal matrix of (B1 + lambda B2): C11 + lambda (C12 + C12^T) + lambda^2 C22.
  Matrix12d normalMatrix(double lambda) const;

  const Matrix12d& c11() const;
  const Matrix12d& c12() const;
  const Matrix12d& c22() const;
  size_t constraintCount() const { return constraints_; }

private:
  void unpack() const;

  void flush() const;

  // Only the distinct products are accumulated: the 10 entries of the symmetric 4x4 scatter times the 18 image
  // entries (9 of l l^T, the 6 non-zero ones of l e^T, the 3 distinct ones of e e^T), as packed_ = sum s g^T. Groups
  // are batched and added as one small matrix product, which vectorises (one outer product per group does not: with
  // 2 constraints per line it was most of the time). The 12x12 matrices are built on demand.
  static constexpr int kPackedImage = 18;
  static constexpr int kBatch = 64;
  mutable Eigen::Matrix<double, 10, kPackedImage> packed_;
  mutable Eigen::Matrix<double, 10, kBatch> batch_scatter_;
  mutable Eigen::Matrix<double, kPackedImage, kBatch> batch_image_;
  mutable int batched_ = 0;
  size_t constraints_ = 0;
  mutable bool unpacked_ = false;
  mutable Matrix12d c11_;
  mutable Matrix12d c12_;
  mutable Matrix12d c22_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_DLT_SYSTEM_H
