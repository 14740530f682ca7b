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

// A straight drive the route makes first: from the free cell nearest `start` along `direction` (on the floor) for up
// to `max_length_m`, as far as the floor stays free.
struct ViewLeg
{
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  Eigen::Vector2d direction = Eigen::Vector2d::UnitX();
  double max_length_m = 4.0;
};

struct RoutePlanOptions
{
  double clearance_m = 0.45;    // from walls and obstacles, for every cell the route passes
  double lane_spacing_m = 1.5;  // distance between the coverage lanes
  double cell_m = 0.1;          // occupancy grid resolution
  double max_length_m = 0.0;    // > 0: the route is cut at this length
  // > 0: look-arounds about this far apart along the lanes (the first half that far from the start). A look-around
  // drives a small square with a 90 deg turn in place at each corner, so the Xtion, which looks where the robot
  // drives, faces every direction there: lanes alone show the walls along them only at grazing angles.
  double look_around_spacing_m = 0.0;
  double look_around_side_m = 0.3;
  // Driven before the lanes, in this order, each joined to the next by the shortest free path (generate_world: one
  // per fixed camera, along the installer's prior of its viewing direction, so the Xtion sees what it sees).
  std::vector<ViewLeg> view_legs;
};

// A place the robot drives to after its route, and where it then looks (a refused camera's survey hint region).
struct Visit
{
  Eigen::Vector2d standpoint = Eigen::Vector2d::Zero();
  Eigen::Vector2d look_direction = Eigen::Vector2d::UnitX();
};

struct VisitOptions
{
  double clearance_m = 0.45;  // as RoutePlanOptions
  double cell_m = 0.1;
  double max_offset_m = 3.0;  // a standpoint without a free cell this near is skipped
  // At a standpoint the robot, which faces where it drives, sweeps its view: three legs of leg_m, turned by
  // +sweep_deg, -sweep_deg and 0 from the look direction, so that it ends facing it (0: one leg along it).
  double leg_m = 0.3;
  double sweep_deg = 30.0;
};

// The route extended by visits, nearest first (straight-line distance from where the robot is): from the route's
// end along the shortest free path to the free cell nearest the standpoint, then the sweep (or, when the floor ahead
// is blocked, the same sweep ending at the standpoint, or a single leg along the look direction either way), so the
// robot stands there looking along the look direction at the end of each visit. A visit with no free cell within
// max_offset_m, or no free leg along its direction, is left out and counted in `skipped`.
// Errors: the route is empty, or its end has no free cell within max_offset_m.
Expected<std::vector<Eigen::Vector2d>> appendVisits(const FloorPlan& plan, std::vector<Eigen::Vector2d> route,
                                                    const std::vector<Visit>& visits, const VisitOptions& options = {},
                                                    size_t* skipped = nullptr);

// Distance from a point to a convex quadrilateral (0 inside).
double distanceToFootprint(const Eigen::Vector2d& p, const Footprint& quad);

// Waypoints along the view legs, then from a corner of the largest free region along lanes parallel to the walkable
// area's longer side, with look-arounds where the options ask for them and the square is free. A view leg whose
// start has no free cell within 3 m or that is shorter than 0.5 m is left out.
// Errors: no free cell (the space is narrower than twice the clearance or filled).
Expected<std::vector<Eigen::Vector2d>> planCoverageRoute(const FloorPlan& plan, const RoutePlanOptions& options);

// Length of a polyline, m.
double polylineLength(const std::vector<Eigen::Vector2d>& points);

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_ROUTE_PLANNER_H
