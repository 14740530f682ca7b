// Conversions between ROS messages and the core library's types. No geometry beyond the frame conventions.
#ifndef INSITU_CALIBRATION_ROS_CONVERSIONS_H
#define INSITU_CALIBRATION_ROS_CONVERSIONS_H

#include <string>
#include <vector>

#include <geometry_msgs/Point.h>
#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "insitu_calibration/CalibrationResult.h"
#include "insitu_calibration/calibration.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/lines/rgbd_frame.h"

namespace insitu_calibration
{
// REP 103: the optical frame (z forward, x right, y down) seen from the body frame (x forward, y left, z up).
Eigen::Quaterniond bodyFromOptical();

// A latched-CameraInfo message of a calibration: K, the plumb_bob approximation D, R = I, P = [K | 0].
sensor_msgs::CameraInfo toCameraInfo(const CalibrationFile& calibration, const std::string& optical_frame);

// map -> <name>_link (body frame at the optical centre) and <name>_link -> <name>_optical_frame.
std::vector<geometry_msgs::TransformStamped> cameraTransforms(const CalibrationFile& calibration,
                                                              const std::string& world_frame,
                                                              const std::string& link_frame,
                                                              const std::string& optical_frame, const ros::Time& stamp);

// The service's per-camera result.
insitu_calibration::CalibrationResult toResultMsg(const CalibrationFile& file, const CameraCalibration* result,
                                                  const std::string& world_frame);

Eigen::Isometry3d toEigen(const geometry_msgs::Transform& transform);
// A point of a marker.
geometry_msgs::Point toPointMsg(const Eigen::Vector3d& point);

// An RGB-D frame of the core from the Xtion's messages and the optical frame's pose in the map. Errors: images that
// cv_bridge cannot convert (kInvalidInput); the frame's content is checked by the core (validateFrame).
Expected<RgbdFrame> toRgbdFrame(const sensor_msgs::Image& rgb, const sensor_msgs::Image& depth,
                                const sensor_msgs::CameraInfo& info, const Eigen::Isometry3d& T_map_camera);

// An 8-bit grey image of a fixed camera's message. Errors: an encoding cv_bridge cannot convert.
Expected<cv::Mat> toGrey(const sensor_msgs::Image& image);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ROS_CONVERSIONS_H
