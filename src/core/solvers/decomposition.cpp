#include "insitu_calibration/solvers/decomposition.h"

#include <cmath>

#include <Eigen/LU>
#include <Eigen/QR>

namespace insitu_calibration
{
Expected<DecomposedProjection> decomposeProjection(const Matrix34d& projection,
                                                   const std::vector<Eigen::Vector3d>& scene_points)
{
  if (!projection.allFinite())
    return Error(ErrorCode::kInvalidInput, "the projection matrix holds NaN or infinite values");
  Matrix34d p = projection;
  Eigen::Matrix3d m = p.leftCols<3>();
  const double det = m.determinant();
  const double scale = m.row(2).norm();
  if (!(scale > 0.0) || !(std::abs(det) > 1e-14 * std::pow(m.norm(), 3)))
    return Error(ErrorCode::kDegenerate, "the projection matrix's left 3x3 block is singular (no finite camera)");
  // det(K R) = det(K) > 0 for a camera with positive focal lengths and a proper rotation.
  p /= (det > 0.0 ? scale : -scale);
  m = p.leftCols<3>();

  // RQ via QR of the row-reversed transpose: with J the exchange matrix, (J M)^T = Q U gives M = (J U^T J)(J Q^T).
  Eigen::Matrix3d j = Eigen::Matrix3d::Zero();
  j(0, 2) = j(1, 1) = j(2, 0) = 1.0;
  Eigen::HouseholderQR<Eigen::Matrix3d> qr((j * m).transpose());
  const Eigen::Matrix3d q = qr.householderQ();
  const Eigen::Matrix3d u = qr.matrixQR().triangularView<Eigen::Upper>();
  Eigen::Matrix3d k = j * u.transpose() * j;
  Eigen::Matrix3d r = j * q.transpose();
  // Make K's diagonal positive: K D, D R with D = diag(sign(K_ii)), D^2 = I.
  const Eigen::Vector3d signs(k(0, 0) < 0 ? -1.0 : 1.0, k(1, 1) < 0 ? -1.0 : 1.0, k(2, 2) < 0 ? -1.0 : 1.0);
  k = k * signs.asDiagonal();
  r = signs.asDiagonal() * r;
  if (r.determinant() < 0.0)
    return Error(ErrorCode::kNoSolution, "the decomposed rotation is a reflection");

  DecomposedProjection out;
  // |row 2 of M| = |K(2,2)| = 1 after the scaling above, so K needs no further normalisation.
  out.intrinsics = Intrinsics::fromMatrix(k);
  out.pose.rotation = r;
  out.pose.translation = k.inverse() * p.col(3);
  out.projection = p;

  if (!scene_points.empty())
  {
    size_t in_front = 0;
    for (const auto& x : scene_points)
      in_front += (out.pose.rotation * x + out.pose.translation).z() > 0.0 ? 1 : 0;
    if (2 * in_front < scene_points.size())
      return Error(ErrorCode::kNoSolution,
                   "the solution places " + std::to_string(scene_points.size() - in_front) + " of " +
                       std::to_string(scene_points.size()) +
                       " scene points behind the camera (wrong or degenerate correspondences, or a "
                       "left-handed world frame)");
  }
  return out;
}

}  // namespace insitu_calibration
