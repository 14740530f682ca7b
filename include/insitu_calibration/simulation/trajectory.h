// The robot's motion along its route and the Xtion's mounting, as openni2_launch names its frames.
//
// The robot starts at the first waypoint facing the second, drives straight legs at the route's speed and turns in
// place at each waypoint at the route's turn rate; with loop it returns to the first waypoint, turns to face the
// second again and repeats, otherwise it stays at the last waypoint. base_link is on the floor (z = 0).
#ifndef INSITU_CALIBRATION_SIMULATION_TRAJECTORY_H
#define INSITU_CALIBRATION_SIMULATION_TRAJECTORY_H

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace simulation
{
struct Pose2d
{
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;
};

class RouteTrajectory
{
public:
  explicit RouteTrajectory(const Route& route);

  Pose2d at(double t) const;  // seconds since the start
  Eigen::Isometry3d mapFromBase(double t) const;
  double lapDuration() const { return lap_; }
  // Points along the driven path, every step metres (for tests and the documentation).
  std::vector<Eigen::Vector2d> pathPoints(double step) const;

private:
  struct Phase
  {
    double t0, t1;
    Pose2d from, to;
  };
  std::vector<Phase> phases_;
  double lap_ = 0.0;
  bool loop_ = true;
};

Eigen::Isometry3d pose2dToIsometry(const Pose2d& pose);

struct NamedTransform
{
  std::string parent;
  std::string child;
  Eigen::Isometry3d transform;  // child frame in the parent frame (parent_from_child)
};

// base_link -> camera_link -> camera_{rgb,depth}_frame -> camera_{rgb,depth}_optical_frame.
std::vector<NamedTransform> xtionStaticTransforms(const XtionConfig& xtion);
// The RGB optical frame (where registered depth lives too) in base_link.
Eigen::Isometry3d baseFromRgbOptical(const XtionConfig& xtion);

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_TRAJECTORY_H
