// The Xtion's camera models and its depth-to-point-cloud conversion, ROS-free: the driver node (src/ros/
// xtion_driver.cpp) only copies these into sensor_msgs. Pixel (0,0) is the centre of the top-left pixel.
#ifndef INSITU_CALIBRATION_DRIVERS_DEPTH_CLOUD_H
#define INSITU_CALIBRATION_DRIVERS_DEPTH_CLOUD_H

#include <array>
#include <cstddef>
#include <cstdint>

namespace insitu_calibration
{
namespace drivers
{
// A pinhole camera's K (3x3) and P (3x4), row-major as in sensor_msgs/CameraInfo, at an image size.
struct PinholeMatrices
{
  int width = 0;
  int height = 0;
  std::array<double, 9> K{};
  std::array<double, 12> P{};
};

// Intrinsics from the fields of view (radians), principal point at the image centre.
PinholeMatrices pinholeFromFieldOfView(int width, int height, double hfov_rad, double vfov_rad);

// A calibration made at another resolution of the same aspect ratio (1280x1024 vs 640x512), scaled to
// width x height. False (nothing changed) when the aspect ratios differ by more than 0.1 % or the calibration's size
// is unknown.
bool scalePinhole(PinholeMatrices& m, int width, int height);

// A 16-bit depth image in mm (0 = no depth) and, optionally, an 8-bit RGB image registered to it (any size: pixels
// are taken at the same relative position).
struct DepthImageView
{
  const uint8_t* data = nullptr;
  int width = 0;
  int height = 0;
  size_t step = 0;  // bytes per row
};
struct RgbImageView
{
  const uint8_t* data = nullptr;
  int width = 0;
  int height = 0;
  size_t step = 0;
};

// Where each field of a point goes in the output buffer (pcl::PointXYZRGB's layout in a PointCloud2, for example).
struct PointLayout
{
  size_t point_step = 0;
  size_t x_offset = 0;
  size_t y_offset = 0;
  size_t z_offset = 0;
  size_t rgb_offset = 0;  // 4 bytes b, g, r, a (pcl's packed rgb float)
};

// Writes width x height points (row-major) into `out` (at least width * height * point_step bytes): x = (u - cx) /
// fx z, y = (v - cy) / fy z, z in metres; NaN where depth is 0. Colours from `rgb` when given, else black.
void depthToPoints(const DepthImageView& depth, const RgbImageView* rgb, const std::array<double, 9>& K,
                   const PointLayout& layout, uint8_t* out);
}  // namespace drivers
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_DRIVERS_DEPTH_CLOUD_H
