// One frame of the robot's RGB-D camera (Asus Xtion): colour, depth registered to the colour image, the colour
// camera's sensor_msgs/CameraInfo, and the pose of its optical frame in the map at the frame's stamp.
#ifndef INSITU_CALIBRATION_LINES_RGBD_FRAME_H
#define INSITU_CALIBRATION_LINES_RGBD_FRAME_H

#include <array>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"

namespace insitu_calibration
{
// The parts of a sensor_msgs/CameraInfo the line extraction uses.
struct RgbdCamera
{
  int width = 0;  // camera_info width and height, px
  int height = 0;
  Intrinsics intrinsics;              // K
  std::array<double, 5> plumb_bob{};  // D (k1, k2, p1, p2, k3); zeros for a rectified or distortion-free image

  // Errors (kInvalidInput): non-positive or non-finite focal lengths, non-finite principal point or distortion,
  // non-positive size.
  Status validate() const;
  // Distorted pixel -> undistorted normalised image coordinates (the ray is (x, y, 1)). plumb_bob is inverted by
  // fixed-point iteration (as cv::undistortPoints).
  Eigen::Vector2d normalize(const Eigen::Vector2d& pixel) const;
  bool hasDistortion() const;
};

struct RgbdFrame
{
  cv::Mat rgb;    // 8UC3 BGR (8UC1, 8UC4, 16UC1 and 32FC1 accepted too)
  cv::Mat depth;  // registered to rgb: 16UC1 millimetres or 32FC1 metres; 0 or NaN = no measurement
  RgbdCamera camera;
  Eigen::Isometry3d T_map_camera = Eigen::Isometry3d::Identity();  // optical frame -> map, at stamp
  double stamp = 0.0;                                              // seconds
};

// Every check the extraction needs before touching the data (kInvalidInput): camera valid, images non-empty,
// rgb and depth of the camera_info's size, depth type 16UC1 or 32FC1, finite pose with a rotation.
Status validateFrame(const RgbdFrame& frame);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_RGBD_FRAME_H
