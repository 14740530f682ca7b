// calibration_node: accumulates the robot's survey into a 3D line map and calibrates the building's fixed cameras
// on request (~calibrate), publishing them into tf2 (see README, "On the robot: calibration_node").
#include <cstdio>
#include <cstring>

#include <ros/ros.h>

#include "insitu_calibration/refine/refinement.h"
#include "insitu_calibration/ros/calibration_server.h"

namespace
{
const char* const kUsage =
    "calibration_node: calibrates a building's fixed cameras from a robot's RGB-D survey (README, \"On the robot:\n"
    "calibration_node\").\n"
    "Usage: roslaunch insitu_calibration survey.launch [cameras:=/path/cameras.yaml]\n"
    "       rosrun insitu_calibration calibration_node (with the private parameter ~cameras loaded)\n"
    "Services: ~calibrate, ~status, ~reset, ~save. Exit status: 0 after a normal shutdown, 1 on a configuration\n"
    "error.\n";
}  // namespace

int main(int argc, char** argv)
{
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0)
    {
      std::fputs(kUsage, stdout);
      return 0;
    }
  ros::init(argc, argv, "calibration_node");
  insitu_calibration::quietSolverLogging();
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  insitu_calibration::CalibrationServer server(nh, private_nh);
  if (!server.ok())
    return 1;  // a configuration error, reported by the server (ROS_FATAL)
  // Two threads: RGB-D processing and service calls do not wait for each other's callbacks to be dispatched.
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ros::waitForShutdown();
  return 0;
}
