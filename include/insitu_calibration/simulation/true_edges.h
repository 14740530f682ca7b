// The world's true 3D edges (segments in map), for evaluating line extraction against what the images show:
//   crease   a polygon edge shared by non-coplanar surfaces (room corners, box edges)
//   seam     a polygon edge shared by coplanar surfaces only (may show no contrast)
//   outline  a polygon edge of one surface only (poster and door borders, table tops, occluding contours)
//   texture  a boundary inside a surface between texture regions of different colours (checker, stripes, rectangles)
// File: {world: NAME, frame_id: map, edges: [{start: [x, y, z], end: [x, y, z], kind: K, surfaces: [..]}, ...]}.
#ifndef INSITU_CALIBRATION_SIMULATION_TRUE_EDGES_H
#define INSITU_CALIBRATION_SIMULATION_TRUE_EDGES_H

#include <string>
#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/error.h"
#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace simulation
{
struct TrueEdge
{
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
  Eigen::Vector3d end = Eigen::Vector3d::Zero();
  std::string kind;                   // crease, seam, outline or texture
  std::vector<std::string> surfaces;  // names of the surfaces it belongs to
};

std::vector<TrueEdge> computeTrueEdges(const World& world);

std::string formatTrueEdges(const std::vector<TrueEdge>& edges, const std::string& world_name);
Status saveTrueEdges(const std::string& path, const std::vector<TrueEdge>& edges, const std::string& world_name);
Expected<std::vector<TrueEdge>> loadTrueEdges(const std::string& path);

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_TRUE_EDGES_H
