// calibration_node: accumulates the robot's survey into a 3D line map and calibrates the building's fixed cameras
// on request (~calibrate), publishing them into tf2 (see README, "The calibration node").
#include <ros/ros.h>

#include "insitu_calibration/refine/refinement.h"
#include "insitu_calibration/ros/calibration_server.h"

int main(int argc, char** argv)
{
  ros::init(argc, argv, "calibration_node");
  insitu_calibration::quietSolverLogging();
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  insitu_calibration::CalibrationServer server(nh, private_nh);
  // Two threads: RGB-D processing and service calls do not wait for each other's callbacks to be dispatched.
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ros::waitForShutdown();
  return 0;
}
