// The calibration node's ROS side: parameters, subscriptions (Xtion RGB-D with tf2 poses, fixed cameras through
// image_transport), services (~calibrate, ~status, ~reset, ~save) and outputs (one static tf broadcaster, latched
// CameraInfo, YAML files, markers, overlay images). The work is done by the core (RgbdLineExtractor, LineMap,
// FixedCamera); this class converts and calls.
#ifndef INSITU_CALIBRATION_ROS_CALIBRATION_SERVER_H
#define INSITU_CALIBRATION_ROS_CALIBRATION_SERVER_H

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <image_transport/image_transport.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include "insitu_calibration/Calibrate.h"
#include "insitu_calibration/Reset.h"
#include "insitu_calibration/CalibrationStatus.h"
#include "insitu_calibration/survey/survey.h"

namespace insitu_calibration
{
class CalibrationServer
{
public:
  CalibrationServer(ros::NodeHandle nh, ros::NodeHandle private_nh);

private:
  // The ROS side of a fixed camera; its core is survey_->camera(name).
  struct Camera
  {
    image_transport::Subscriber subscriber;
    ros::Publisher info_publisher;
    image_transport::Publisher overlay_publisher;
    std::string link_frame;
    std::string optical_frame;
  };

  bool loadParameters();
  void rgbdCallback(const sensor_msgs::ImageConstPtr& rgb, const sensor_msgs::ImageConstPtr& depth,
                    const sensor_msgs::CameraInfoConstPtr& info);
  void fixedImageCallback(const std::string& name, const sensor_msgs::ImageConstPtr& image);

  bool calibrateService(Calibrate::Request& request, Calibrate::Response& response);
  bool statusService(CalibrationStatus::Request& request, CalibrationStatus::Response& response);
  bool resetService(Reset::Request& request, Reset::Response& response);
  bool saveService(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);

  // Publishes every calibration: tf (one broadcaster, all cameras at once), CameraInfo, markers, overlays.
  void publishCalibrations();
  void publishMarkers();
  void loadSavedCalibrations();
  Status saveCalibration(const std::string& name);
  std::string calibrationPath(const std::string& name) const;
  std::vector<std::string> selectCameras(const std::string& name, std::string* error) const;

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  image_transport::ImageTransport it_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;

  using SyncPolicy =
      message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::Image, sensor_msgs::CameraInfo>;
  message_filters::Subscriber<sensor_msgs::Image> rgb_subscriber_;
  message_filters::Subscriber<sensor_msgs::Image> depth_subscriber_;
  message_filters::Subscriber<sensor_msgs::CameraInfo> info_subscriber_;
  std::unique_ptr<message_filters::Synchronizer<SyncPolicy>> synchronizer_;

  ros::ServiceServer calibrate_server_;
  ros::ServiceServer status_server_;
  ros::ServiceServer reset_server_;
  ros::ServiceServer save_server_;
  ros::Publisher marker_publisher_;
  ros::WallTimer marker_timer_;

  // Parameters
  std::string world_frame_;
  std::string odom_frame_;  // empty: no odometry for the map adjustment
  std::string output_directory_;
  double tf_timeout_s_ = 0.2;

  // State, guarded by mutex_ (callbacks run on an AsyncSpinner's threads).
  mutable std::mutex mutex_;
  std::unique_ptr<Survey> survey_;
  std::map<std::string, Camera> cameras_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ROS_CALIBRATION_SERVER_H
