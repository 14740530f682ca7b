#include "insitu_calibration/test_support/edges_in_view.h"

#include "insitu_calibration/simulation/true_edges.h"

namespace insitu_calibration
{
std::vector<Segment3d> edgesSeenInView(const simulation::World& world, const CameraModel& camera,
                                       const simulation::RenderedView& view)
{
  std::vector<Segment3d> out;
  for (const auto& e : simulation::computeTrueEdges(world))
  {
    const Eigen::Vector3d m = 0.5 * (e.start + e.end);
    const auto p = camera.project(m);
    if (!p || p->x() < 0 || p->y() < 0 || p->x() > view.depth.cols - 1 || p->y() > view.depth.rows - 1)
      continue;
    const float depth = view.depth.at<float>(static_cast<int>(p->y() + 0.5), static_cast<int>(p->x() + 0.5));
    if (camera.toCamera(m).z() < depth + 0.05)
      out.push_back({e.start, e.end});
  }
  return out;
}
}  // namespace insitu_calibration
