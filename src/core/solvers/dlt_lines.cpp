#include "insitu_calibration/solvers/dlt_lines.h"

#include <cmath>

namespace insitu_calibration
{
void addLineConstraints(const LineCorrespondence& line, const ImageNormalization& image_norm,
                        const WorldNormalization& world_norm, DltSystem* system)
{
  if (line.partCount() == 0 || line.world.empty())
    return;
  // sum_k M_k M_k^T over the homogeneous normalised world points, distinct entries only.
  double s[10] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  for (const auto& x : line.world)
  {
    const Eigen::Vector3d m = world_norm.apply(x);
    s[0] += m.x() * m.x();
    s[1] += m.x() * m.y();
    s[2] += m.x() * m.z();
    s[3] += m.x();
    s[4] += m.y() * m.y();
    s[5] += m.y() * m.z();
    s[6] += m.y();
    s[7] += m.z() * m.z();
    s[8] += m.z();
    s[9] += 1.0;
  }

  double ll[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  double le[6] = {0, 0, 0, 0, 0, 0};
  double ee[3] = {0, 0, 0};
  size_t used_parts = 0;
  Eigen::Vector2d a = image_norm.apply(line.image[0]);
  for (size_t j = 1; j < line.image.size(); ++j)
  {
    const Eigen::Vector2d b = image_norm.apply(line.image[j]);
    // l_d = [a; 1] x [b; 1] and e12, both divided by |l_d(0:2)| (= the part's length).
    const double l0 = a.y() - b.y();
    const double l1 = b.x() - a.x();
    const double length = std::sqrt(l0 * l0 + l1 * l1);
    if (length > 0.0)
    {
      const double inv = 1.0 / length;
      const double sa = a.squaredNorm();
      const double sb = b.squaredNorm();
      const double l[3] = {l0 * inv, l1 * inv, (a.x() * b.y() - a.y() * b.x()) * inv};
      const double e[2] = {(a.y() * sb - b.y() * sa) * inv, (b.x() * sa - a.x() * sb) * inv};
      for (int r = 0; r < 3; ++r)
      {
        for (int c = 0; c < 3; ++c)
          ll[3 * r + c] += l[r] * l[c];
        le[2 * r] += l[r] * e[0];
        le[2 * r + 1] += l[r] * e[1];
      }
      ee[0] += e[0] * e[0];
      ee[1] += e[0] * e[1];
      ee[2] += e[1] * e[1];
      ++used_parts;
    }
    a = b;
  }
  system->addPackedGroup(s, ll, le, ee, used_parts * line.world.size());
}

}  // namespace insitu_calibration
