// The closest OpenCV/ROS plumb_bob model to a division model, so image_proc and every tool that reads a
// sensor_msgs/CameraInfo can rectify with it. plumb_bob maps normalised undistorted coordinates x_u to distorted ones
// x_d = x_u (1 + k1 r^2 + k2 r^4 + k3 r^6) (tangential terms p1 = p2 = 0, which a radial model has none of).
#ifndef INSITU_CALIBRATION_CAMERA_PLUMB_BOB_H
#define INSITU_CALIBRATION_CAMERA_PLUMB_BOB_H

#include <array>

#include "insitu_calibration/camera/camera_model.h"

namespace insitu_calibration
{
struct PlumbBobFit
{
  std::array<double, 5> coefficients{};  // k1, k2, p1, p2, k3: ROS's order
  double max_error_px = 0.0;             // over the image, of plumb_bob against the division model
  double rms_error_px = 0.0;
};

// Least squares over a grid of distorted pixels covering the image.
PlumbBobFit fitPlumbBob(const Intrinsics& intrinsics, const DivisionModel& distortion, int image_width,
                        int image_height);

// OpenCV's radial plumb_bob distortion of a normalised point (used to measure the fit).
Eigen::Vector2d applyPlumbBob(const std::array<double, 5>& coefficients, const Eigen::Vector2d& normalized);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_CAMERA_PLUMB_BOB_H
