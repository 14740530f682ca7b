// A coverage route for the simulated robot: boustrophedon lanes over the free floor of a rectangular space, joined by
// shortest paths on an occupancy grid around the obstacles, and straightened into waypoints whose straight legs keep
// the clearance (generate_world uses it; the legs are what RouteTrajectory drives).
#ifndef INSITU_CALIBRATION_SIMULATION_ROUTE_PLANNER_H
#define INSITU_CALIBRATION_SIMULATION_ROUTE_PLANNER_H

#include <array>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "insitu_calibration/error.h"

namespace insitu_calibration
{
namespace simulation
{
using Footprint = std::array<Eigen::Vector2d, 4>;  // a convex quadrilateral on the floor (an obstacle's plan)

struct FloorPlan
{
  Eigen::AlignedBox2d walkable;      // the space the robot drives in (its walls are its border)
  std::vector<Footprint> obstacles;  // everything standing on the floor below the robot's height
};

struct RoutePlanOptions
{
  double clearance_m = 0.45;    // from walls and obstacles, for every cell the route passes
  double lane_spacing_m = 1.5;  // distance between the coverage lanes
  double cell_m = 0.1;          // occupancy grid resolution
  double max_length_m = 0.0;    // > 0: the route is cut at this length
};

// Distance from a point to a convex quadrilateral (0 inside).
double distanceToFootprint(const Eigen::Vector2d& p, const Footprint& quad);

// Waypoints from a corner of the largest free region along lanes parallel to the walkable area's longer side.
// Errors: no free cell (the space is narrower than twice the clearance or filled).
Expected<std::vector<Eigen::Vector2d>> planCoverageRoute(const FloorPlan& plan, const RoutePlanOptions& options);

// Length of a polyline, m.
double polylineLength(const std::vector<Eigen::Vector2d>& points);

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_ROUTE_PLANNER_H
