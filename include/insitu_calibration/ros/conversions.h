// Conversions between ROS messages and the core library's types. No geometry beyond the frame conventions.
#ifndef INSITU_CALIBRATION_ROS_CONVERSIONS_H
#define INSITU_CALIBRATION_ROS_CONVERSIONS_H

#include <string>
#include <vector>

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>

#include "insitu_calibration/CalibrationResult.h"
#include "insitu_calibration/calibration.h"
#include "insitu_calibration/io/calibration_file.h"

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

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ROS_CONVERSIONS_H
