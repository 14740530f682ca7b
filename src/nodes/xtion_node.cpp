// xtion_node: an Asus Xtion (or an .oni recording, or OpenNI2's DummyDevice) through OpenNI2, published like
// openni2_launch. Parameters, topics and faults: docs/xtion.md.
#include <csignal>
#include <cstdio>
#include <cstring>

#include <ros/ros.h>

#include "insitu_calibration/ros/xtion_driver.h"

namespace
{
volatile std::sig_atomic_t g_stop = 0;
void onSignal(int)
{
  g_stop = 1;
}
}  // namespace

int main(int argc, char** argv)
{
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0)
    {
      std::puts(
          "xtion_node: an Asus Xtion, an .oni recording or OpenNI2's DummyDevice, published like openni2_launch.\n"
          "Usage: roslaunch insitu_calibration xtion.launch [device_uri:=...] (parameters and topics: docs/xtion.md)");
      return 0;
    }
  // Our own SIGINT/SIGTERM handling: stop the streams and close the device before ROS shuts down.
  ros::init(argc, argv, "xtion_node", ros::init_options::NoSigintHandler);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // INFO lines reach a log file as they happen
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  insitu_calibration::XtionDriver driver(nh, pnh);
  const insitu_calibration::Status started = driver.start();
  if (!started)
  {
    ROS_FATAL_STREAM("xtion_node: " << started.error().message());
    return 1;
  }
  ros::AsyncSpinner spinner(1);  // camera_info_manager's set_camera_info services
  spinner.start();
  while (!g_stop && ros::ok())
    ros::WallDuration(0.1).sleep();
  driver.stop();
  spinner.stop();
  ROS_INFO("xtion_node: streams stopped, device closed");
  ros::shutdown();
  return 0;
}
