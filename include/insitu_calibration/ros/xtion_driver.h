// The Xtion driver node's ROS side: reads its parameters, runs an OpenniDevice (include/insitu_calibration/drivers/)
// on a worker thread and publishes what openni2_launch publishes:
//   rgb/image_raw (rgb8) + rgb/camera_info
//   depth_registered/image_raw (16UC1, millimetres, 0 = no return) + depth_registered/camera_info
//   depth_registered/points (sensor_msgs/PointCloud2, x y z rgb; only with ~publish_points)
// relative to the node's namespace (launch/xtion.launch puts it in /camera), and the static transforms
// camera_link -> camera_rgb_optical_frame and camera_link -> camera_depth_optical_frame. Faults (no device, device
// unplugged, unsupported mode, unreadable .oni) are logged with what to do, rate-limited, and retried every
// ~retry_period seconds; the worker blocks (never spins) while it waits.
#ifndef INSITU_CALIBRATION_ROS_XTION_DRIVER_H
#define INSITU_CALIBRATION_ROS_XTION_DRIVER_H

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include <camera_info_manager/camera_info_manager.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include "insitu_calibration/drivers/frame_stamper.h"
#include "insitu_calibration/drivers/openni_device.h"
#include "insitu_calibration/error.h"

namespace insitu_calibration
{
class XtionDriver
{
public:
  // nh: where the topics go (the node's namespace); pnh: the private parameters.
  XtionDriver(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~XtionDriver();  // stop()

  // Reads and checks the parameters, advertises, publishes the static transforms and starts the worker. An error
  // (a malformed parameter) says which parameter and what it should look like.
  Status start();
  // Stops the worker, then the streams, then closes the device. Safe to call twice.
  void stop();

private:
  struct Parameters
  {
    drivers::OpenniConfig device;
    double retry_period_s = 2.0;
    double frame_timeout_s = 3.0;
    double fault_report_period_s = 30.0;
    bool publish_points = false;
    bool publish_tf = true;
    std::string camera_link_frame_id = "camera_link";
    std::string rgb_frame_id = "camera_rgb_optical_frame";
    std::string depth_frame_id = "camera_depth_optical_frame";
    std::vector<double> rgb_xyz{0.0, -0.045, 0.0};  // rgb optical frame origin in camera_link (m)
    std::vector<double> depth_xyz{0.0, -0.02, 0.0};
    std::string rgb_camera_info_url;
    std::string depth_camera_info_url;
  };

  Status readParameters();
  void publishStaticTransforms();
  void run();  // the worker
  void waitFor(double seconds);
  void onOpened();
  void onFrame(const drivers::FrameView& frame);
  void publishPoints(const sensor_msgs::ImageConstPtr& depth, const sensor_msgs::CameraInfo& info);
  sensor_msgs::CameraInfo cameraInfo(drivers::StreamKind kind, int width, int height);
  void reportFault(const std::string& message);
  void reportRecovered();

  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  Parameters params_;
  image_transport::ImageTransport it_;
  image_transport::CameraPublisher rgb_pub_;
  image_transport::CameraPublisher depth_pub_;
  ros::Publisher points_pub_;
  std::unique_ptr<camera_info_manager::CameraInfoManager> rgb_info_manager_;
  std::unique_ptr<camera_info_manager::CameraInfoManager> depth_info_manager_;
  tf2_ros::StaticTransformBroadcaster static_tf_;

  drivers::OpenniDevice device_;
  drivers::FrameStamper stamper_;
  sensor_msgs::ImageConstPtr last_color_;  // for the colours of the point cloud

  std::thread worker_;
  std::atomic<bool> running_{false};
  std::mutex wait_mutex_;
  std::condition_variable wake_;

  // Fault reporting: a new message at once, the same one again at most every fault_report_period_s.
  std::string last_fault_;
  std::chrono::steady_clock::time_point fault_since_;
  std::chrono::steady_clock::time_point last_fault_report_;
  int fault_attempts_ = 0;
  bool in_fault_ = false;
  std::chrono::steady_clock::time_point last_frame_time_;
  bool warned_fov_ = false;
  bool warned_registration_ = false;
  bool warned_sync_ = false;
  bool warned_modes_ = false;
  bool warned_info_size_[2] = {false, false};
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ROS_XTION_DRIVER_H
