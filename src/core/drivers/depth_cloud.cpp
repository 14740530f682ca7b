#include "insitu_calibration/drivers/depth_cloud.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

namespace insitu_calibration
{
namespace drivers
{
PinholeMatrices pinholeFromFieldOfView(int width, int height, double hfov_rad, double vfov_rad)
{
  PinholeMatrices m;
  m.width = width;
  m.height = height;
  const double fx = 0.5 * width / std::tan(0.5 * hfov_rad);
  const double fy = 0.5 * height / std::tan(0.5 * vfov_rad);
  const double cx = 0.5 * (width - 1);
  const double cy = 0.5 * (height - 1);
  m.K = {fx, 0, cx, 0, fy, cy, 0, 0, 1};
  m.P = {fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0};
  return m;
}

bool scalePinhole(PinholeMatrices& m, int width, int height)
{
  if (m.width <= 0 || m.height <= 0)
    return false;
  const double sx = static_cast<double>(width) / m.width;
  const double sy = static_cast<double>(height) / m.height;
  if (std::abs(sx - sy) > 1e-3 * std::max(sx, sy))
    return false;
  // Pixel (0,0) is the centre of the top-left pixel: a centre c scales as (c + 0.5) * s - 0.5.
  m.K[0] *= sx;
  m.K[2] = (m.K[2] + 0.5) * sx - 0.5;
  m.K[4] *= sy;
  m.K[5] = (m.K[5] + 0.5) * sy - 0.5;
  m.P[0] *= sx;
  m.P[2] = (m.P[2] + 0.5) * sx - 0.5;
  m.P[3] *= sx;
  m.P[5] *= sy;
  m.P[6] = (m.P[6] + 0.5) * sy - 0.5;
  m.P[7] *= sy;
  m.width = width;
  m.height = height;
  return true;
}

void depthToPoints(const DepthImageView& depth, const RgbImageView* rgb, const std::array<double, 9>& K,
                   const PointLayout& layout, uint8_t* out)
{
  const float bad = std::numeric_limits<float>::quiet_NaN();
  // Per-column and per-row factors: x = (u - cx) / fx * z, y = (v - cy) / fy * z.
  std::vector<float> column_factor(depth.width);
  std::vector<size_t> color_column(depth.width, 0);
  for (int u = 0; u < depth.width; ++u)
  {
    column_factor[u] = static_cast<float>((u - K[2]) / K[0]);
    if (rgb != nullptr)
      color_column[u] = 3 * (static_cast<size_t>(u) * rgb->width / depth.width);
  }
  uint8_t* point = out;
  for (int v = 0; v < depth.height; ++v)
  {
    const float row_factor = static_cast<float>((v - K[5]) / K[4]);
    const auto* row = reinterpret_cast<const uint16_t*>(depth.data + static_cast<size_t>(v) * depth.step);
    const uint8_t* color_row =
        rgb != nullptr ? rgb->data + static_cast<size_t>(v) * rgb->height / depth.height * rgb->step : nullptr;
    for (int u = 0; u < depth.width; ++u, point += layout.point_step)
    {
      float xyz[3] = {bad, bad, bad};
      if (row[u] != 0)
      {
        xyz[2] = row[u] * 0.001f;
        xyz[0] = column_factor[u] * xyz[2];
        xyz[1] = row_factor * xyz[2];
      }
      std::memcpy(point + layout.x_offset, &xyz[0], sizeof(float));
      std::memcpy(point + layout.y_offset, &xyz[1], sizeof(float));
      std::memcpy(point + layout.z_offset, &xyz[2], sizeof(float));
      uint8_t bgr[4] = {0, 0, 0, 0};  // packed as pcl's rgb float: b, g, r, a
      if (color_row != nullptr)
      {
        const uint8_t* pixel = color_row + color_column[u];
        bgr[0] = pixel[2];
        bgr[1] = pixel[1];
        bgr[2] = pixel[0];
      }
      std::memcpy(point + layout.rgb_offset, bgr, sizeof(bgr));
    }
  }
}
}  // namespace drivers
}  // namespace insitu_calibration
