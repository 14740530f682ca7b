#include "insitu_calibration/simulation/sensor_models.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "insitu_calibration/simulation/random.h"

namespace insitu_calibration
{
namespace simulation
{
namespace
{
// A smooth unit-variance Gaussian field: independent samples on a grid of the given spacing, bilinear in between,
// divided by the interpolation's standard deviation at each pixel.
cv::Mat correlatedField(int width, int height, double spacing, FastRandom& rng)
{
  const int gw = static_cast<int>(std::ceil((width - 1) / spacing)) + 2;
  const int gh = static_cast<int>(std::ceil((height - 1) / spacing)) + 2;
  std::vector<float> grid(static_cast<size_t>(gw) * gh);
  for (float& g : grid)
    g = rng.gaussian();
  cv::Mat field(height, width, CV_32FC1);
  for (int y = 0; y < height; ++y)
  {
    const double gy = y / spacing;
    const int j = static_cast<int>(gy);
    const float fy = static_cast<float>(gy - j);
    float* row = field.ptr<float>(y);
    for (int x = 0; x < width; ++x)
    {
      const double gx = x / spacing;
      const int i = static_cast<int>(gx);
      const float fx = static_cast<float>(gx - i);
      const float w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy, w11 = fx * fy;
      const float* g0 = &grid[static_cast<size_t>(j) * gw + i];
      const float* g1 = g0 + gw;
      const float v = w00 * g0[0] + w10 * g0[1] + w01 * g1[0] + w11 * g1[1];
      row[x] = v / std::sqrt(w00 * w00 + w10 * w10 + w01 * w01 + w11 * w11);
    }
  }
  return field;
}
}  // namespace

double depthGaussianCoefficient(const DepthSensorConfig& config, double focal_px)
{
  const double fb = focal_px * config.baseline_m;
  const double quantisation =
      config.disparity_subpixel > 0.0 ? 1.0 / (fb * config.disparity_subpixel * std::sqrt(12.0)) : 0.0;
  const double total = config.sigma_coefficient;
  return std::sqrt(std::max(0.0, total * total - quantisation * quantisation));
}

cv::Mat simulateXtionDepth(const RenderedView& view, const World& world, const ViewCamera& camera,
                           const DepthSensorConfig& config, bool noise, uint64_t seed)
{
  const int w = view.depth.cols;
  const int h = view.depth.rows;
  cv::Mat out(h, w, CV_16UC1, cv::Scalar(0));
  const Eigen::Matrix3d camera_from_world = camera.world_from_camera.linear().transpose();
  std::vector<Eigen::Vector3d> normals;
  for (const Surface& s : world.surfaces)
    normals.push_back(camera_from_world * s.normal);
  const double cos_max = std::cos(config.max_incidence_deg * M_PI / 180.0);
  const double fb = camera.intrinsics.fx * config.baseline_m;
  const double coefficient = depthGaussianCoefficient(config, camera.intrinsics.fx);
  const double sub = config.disparity_subpixel;
  FastRandom rng(seed);
  cv::Mat field;
  if (noise && config.correlation_px > 0.0)
    field = correlatedField(w, h, config.correlation_px, rng);

  for (int y = 0; y < h; ++y)
  {
    const float* z_row = view.depth.ptr<float>(y);
    const int* id_row = view.surface.ptr<int>(y);
    const float* field_row = field.empty() ? nullptr : field.ptr<float>(y);
    uint16_t* out_row = out.ptr<uint16_t>(y);
    for (int x = 0; x < w; ++x)
    {
      // Draw the noise for every pixel, returned or not, so that the noise of a pixel does not depend on others.
      const float g = field_row ? field_row[x] : (noise ? rng.gaussian() : 0.0f);
      const double z = z_row[x];
      const int id = id_row[x];
      if (id < 0 || !(z >= config.min_range_m && z <= config.max_range_m))
        continue;
      const auto r = camera.ray(x, y);
      if (!r || std::abs(normals[id].dot(*r)) < cos_max * r->norm())
        continue;
      double zq = z;
      if (noise)
      {
        const double zn = z + coefficient * z * z * g;
        if (sub > 0.0 && zn > 0.0)
        {
          const double d = std::round(fb / zn * sub) / sub;
          if (!(d > 0.0))
            continue;
          zq = fb / d;
        }
        else
          zq = zn;
      }
      const long mm = std::lround(zq * 1000.0);
      out_row[x] = static_cast<uint16_t>(std::clamp(mm, 0L, 65535L));
    }
  }
  return out;
}

cv::Mat addImageNoise(const cv::Mat& clean, const ImageNoiseConfig& noise, uint64_t seed)
{
  CV_Assert(clean.type() == CV_8UC3 || clean.type() == CV_8UC1);
  float sigma[256];
  for (int i = 0; i < 256; ++i)
    sigma[i] = static_cast<float>(std::sqrt(noise.read_sigma * noise.read_sigma + noise.shot_gain * i));
  cv::Mat out(clean.size(), clean.type());
  FastRandom rng(seed);
  const int values = clean.cols * clean.channels();
  for (int y = 0; y < clean.rows; ++y)
  {
    const uint8_t* in = clean.ptr<uint8_t>(y);
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int i = 0; i < values; ++i)
    {
      const float v = std::clamp(in[i] + sigma[in[i]] * rng.gaussian(), 0.0f, 255.0f);
      o[i] = static_cast<uint8_t>(v + 0.5f);
    }
  }
  return out;
}

}  // namespace simulation
}  // namespace insitu_calibration
