#include <Eigen/Geometry>

#include "insitu_calibration/solvers/dlt_lines.h"

namespace insitu_calibration
{
void addLineConstraints(const LineCorrespondence& line, const ImageNormalization& image_norm,
                        const WorldNormalization& world_norm, DltSystem* system)
{
  if (line.partCount() == 0 || line.world.empty())
    return;
  Eigen::Matrix4d world_scatter = Eigen::Matrix4d::Zero();
  for (const auto& x : line.world)
  {
    const Eigen::Vector4d m = world_norm.apply(x).homogeneous();
    world_scatter.selfadjointView<Eigen::Upper>().rankUpdate(m);
  }
  world_scatter = world_scatter.selfadjointView<Eigen::Upper>();

  Eigen::Matrix3d ll = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d le = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d ee = Eigen::Matrix3d::Zero();
  size_t used_parts = 0;
  Eigen::Vector2d a = image_norm.apply(line.image[0]);
  for (size_t j = 1; j < line.image.size(); ++j)
  {
    const Eigen::Vector2d b = image_norm.apply(line.image[j]);
    const double sa = a.squaredNorm();
    const double sb = b.squaredNorm();
    const Eigen::Vector3d ld = a.homogeneous().cross(b.homogeneous());
    const double length = ld.head<2>().norm();
    if (length > 0.0)
    {
      const Eigen::Vector3d l = ld / length;
      const Eigen::Vector3d e = Eigen::Vector3d(a.y() * sb - b.y() * sa, b.x() * sa - a.x() * sb, 0.0) / length;
      ll += l * l.transpose();
      le += l * e.transpose();
      ee += e * e.transpose();
      ++used_parts;
    }
    a = b;
  }
  system->addGroup(world_scatter, ll, le, ee, used_parts * line.world.size());
}

}  // namespace insitu_calibration
