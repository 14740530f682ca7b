#include <Eigen/Geometry>

#include "insitu_calibration/solvers/dlt_points.h"

namespace insitu_calibration
{
void addPointConstraints(const PointCorrespondence& point, const ImageNormalization& image_norm,
                         const WorldNormalization& world_norm, DltSystem* system)
{
  const Eigen::Vector4d m = world_norm.apply(point.world).homogeneous();
  const Eigen::Vector2d x = image_norm.apply(point.image);
  const double s2 = x.squaredNorm();
  // Rows of [x]_x and of [e]_x with e = [0, 0, s^2].
  Eigen::Matrix3d rows;
  rows << 0.0, -1.0, x.y(), 1.0, 0.0, -x.x(), -x.y(), x.x(), 0.0;
  Eigen::Matrix3d erows;
  erows << 0.0, -s2, 0.0, s2, 0.0, 0.0, 0.0, 0.0, 0.0;
  // sum over the three rows r of l_r l_r^T = rows^T rows, and likewise for the cross and e terms.
  system->addGroup(m * m.transpose(), rows.transpose() * rows, rows.transpose() * erows, erows.transpose() * erows,
                   2);  // three rows, two of them independent
}

}  // namespace insitu_calibration
