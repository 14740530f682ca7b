#include "insitu_calibration/simulation/sensor_models.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

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

// Flying pixels: the depth of a pixel at a step mixed with its 4-neighbour across the step (the sensor's correlation
// window straddles both surfaces). Reads the original depths, so a pixel's draw does not depend on its neighbours'.
cv::Mat flyingPixels(const cv::Mat& depth, const DepthAppearance& a, FastRandom& rng)
{
  cv::Mat out = depth.clone();
  const int w = depth.cols, h = depth.rows;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
    {
      const float u = rng.uniform(), t = rng.uniform();
      const float z = depth.at<float>(y, x);
      if (!(z > 0.0f) || u >= a.flying_pixels)
        continue;
      float other = z, step = 0.0f;
      for (const auto& [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}})
      {
        const int nx = x + dx, ny = y + dy;
        const float n = (nx >= 0 && ny >= 0 && nx < w && ny < h) ? depth.at<float>(ny, nx) : 0.0f;
        if (n > 0.0f && std::abs(n - z) > step)
        {
          step = std::abs(n - z);
          other = n;
        }
      }
      if (step > a.flying_step_m + 0.02 * z)
        out.at<float>(y, x) = z + t * (other - z);
    }
  return out;
}

enum AppearanceStream : uint64_t
{
  kFlyingStream = 0xF1,
  kLowFrequencyStream = 0xF2,
};
}  // namespace

RenderedView misregisterDepth(const RenderedView& view, const Eigen::Vector2d& shift_px)
{
  RenderedView out;
  out.depth = cv::Mat(view.depth.size(), CV_32FC1, cv::Scalar(0.0f));
  out.surface = cv::Mat(view.depth.size(), CV_32SC1, cv::Scalar(-1));
  const int w = view.depth.cols, h = view.depth.rows;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
    {
      const double sx = x + shift_px.x(), sy = y + shift_px.y();
      const int x0 = static_cast<int>(std::floor(sx)), y0 = static_cast<int>(std::floor(sy));
      const double fx = sx - x0, fy = sy - y0;
      if (x0 < 0 || y0 < 0 || x0 + 1 >= w || y0 + 1 >= h)
        continue;
      const int id = view.surface.at<int>(y0, x0);
      const bool one_surface = id >= 0 && view.surface.at<int>(y0, x0 + 1) == id &&
                               view.surface.at<int>(y0 + 1, x0) == id && view.surface.at<int>(y0 + 1, x0 + 1) == id;
      if (one_surface)
      {
        // 1/z is affine in the image over a plane: interpolate it.
        const double inv =
            (1 - fx) * (1 - fy) / view.depth.at<float>(y0, x0) + fx * (1 - fy) / view.depth.at<float>(y0, x0 + 1) +
            (1 - fx) * fy / view.depth.at<float>(y0 + 1, x0) + fx * fy / view.depth.at<float>(y0 + 1, x0 + 1);
        out.depth.at<float>(y, x) = static_cast<float>(1.0 / inv);
        out.surface.at<int>(y, x) = id;
        continue;
      }
      const int nx = x0 + (fx >= 0.5 ? 1 : 0), ny = y0 + (fy >= 0.5 ? 1 : 0);
      out.depth.at<float>(y, x) = view.depth.at<float>(ny, nx);
      out.surface.at<int>(y, x) = view.surface.at<int>(ny, nx);
    }
  return out;
}

double depthGaussianCoefficient(const DepthSensorConfig& config, double focal_px)
{
  const double fb = focal_px * config.baseline_m;
  const double quantisation =
      config.disparity_subpixel > 0.0 ? 1.0 / (fb * config.disparity_subpixel * std::sqrt(12.0)) : 0.0;
  const double total = config.sigma_coefficient;
  return std::sqrt(std::max(0.0, total * total - quantisation * quantisation));
}

cv::Mat simulateXtionDepth(const RenderedView& rendered, const World& world, const ViewCamera& camera,
                           const DepthSensorConfig& config, bool noise, uint64_t seed,
                           const DepthAppearance& appearance)
{
  const RenderedView registered = appearance.misregistration_px.isZero()
                                      ? RenderedView{}
                                      : misregisterDepth(rendered, appearance.misregistration_px);
  const RenderedView& view = registered.depth.empty() ? rendered : registered;
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
  cv::Mat low_frequency, depth = view.depth;
  if (noise && appearance.low_frequency_coefficient > 0.0)
  {
    FastRandom low_rng(streamSeed(seed, kLowFrequencyStream));
    low_frequency = correlatedField(w, h, appearance.low_frequency_px, low_rng);
  }
  if (noise && appearance.flying_pixels > 0.0)
  {
    FastRandom flying_rng(streamSeed(seed, kFlyingStream));
    depth = flyingPixels(view.depth, appearance, flying_rng);
  }

  for (int y = 0; y < h; ++y)
  {
    const float* z_row = depth.ptr<float>(y);
    const float* low_row = low_frequency.empty() ? nullptr : low_frequency.ptr<float>(y);
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
        const double zn =
            z + z * z * (coefficient * g + (low_row ? appearance.low_frequency_coefficient * low_row[x] : 0.0));
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

cv::Mat applyCameraOptics(const cv::Mat& rgb, const CameraAppearance& a, const ViewCamera& camera)
{
  CV_Assert(rgb.type() == CV_8UC3);
  if (a.blur_sigma_px == 0.0 && a.vignetting == 0.0 && a.exposure == 1.0 && a.white_balance == Eigen::Vector3d::Ones())
    return rgb;
  cv::Mat f;
  rgb.convertTo(f, CV_32FC3);
  if (a.blur_sigma_px > 0.0)
    cv::GaussianBlur(f, f, cv::Size(0, 0), a.blur_sigma_px, a.blur_sigma_px, cv::BORDER_REFLECT);
  const Intrinsics& k = camera.intrinsics;
  const Eigen::Vector3f gain = (a.exposure * a.white_balance).cast<float>();
  for (int y = 0; y < f.rows; ++y)
  {
    cv::Vec3f* row = f.ptr<cv::Vec3f>(y);
    const double ry = (y - k.cy) / k.fy;
    for (int x = 0; x < f.cols; ++x)
    {
      const double rx = (x - k.cx) / k.fx;
      const double cos2 = 1.0 / (1.0 + rx * rx + ry * ry);  // cos^2 of the angle off the optical axis
      const float v = static_cast<float>(1.0 - a.vignetting * (1.0 - cos2 * cos2));
      for (int c = 0; c < 3; ++c)
        row[x][c] *= v * gain[c];
    }
  }
  cv::Mat out;
  f.convertTo(out, CV_8UC3);  // rounds and saturates at 0 and 255
  return out;
}

cv::Mat jpegRoundTrip(const cv::Mat& rgb, int quality)
{
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  std::vector<uint8_t> bytes;
  cv::imencode(".jpg", bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, std::clamp(quality, 1, 100)});
  cv::Mat decoded = cv::imdecode(bytes, cv::IMREAD_COLOR), out;
  cv::cvtColor(decoded, out, cv::COLOR_BGR2RGB);
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
