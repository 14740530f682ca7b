// The Xtion's depth-to-cloud conversion and camera-model scaling (drivers/depth_cloud.h), against hand-computed
// points of a synthetic depth image.
#include <cmath>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "insitu_calibration/drivers/depth_cloud.h"

namespace ic = insitu_calibration;
namespace drv = insitu_calibration::drivers;

namespace
{
struct Point
{
  float x, y, z;
  uint8_t bgra[4];
};

const drv::PointLayout kLayout{sizeof(Point), offsetof(Point, x), offsetof(Point, y), offsetof(Point, z),
                               offsetof(Point, bgra)};
}  // namespace

TEST(DepthCloud, FieldOfViewGivesCentredPinhole)
{
  const drv::PinholeMatrices m = drv::pinholeFromFieldOfView(640, 480, 2.0 * std::atan(0.5), 2.0 * std::atan(0.375));
  EXPECT_NEAR(m.K[0], 640.0, 1e-9);  // 0.5 w / tan(hfov / 2) = 320 / 0.5
  EXPECT_NEAR(m.K[4], 640.0, 1e-9);
  EXPECT_DOUBLE_EQ(m.K[2], 319.5);
  EXPECT_DOUBLE_EQ(m.K[5], 239.5);
  EXPECT_DOUBLE_EQ(m.P[0], m.K[0]);
  EXPECT_DOUBLE_EQ(m.P[6], m.K[5]);
}

TEST(DepthCloud, ScalingKeepsPixelCentres)
{
  drv::PinholeMatrices m = drv::pinholeFromFieldOfView(1280, 1024, 1.0, 0.85);
  m.K[2] = 640.0;  // a calibrated principal point half a pixel right of the centre
  m.P[2] = 640.0;
  m.P[3] = 25.6;  // a stereo baseline term (fx Tx) scales with fx
  const double fx = m.K[0];
  ASSERT_TRUE(drv::scalePinhole(m, 640, 512));
  EXPECT_EQ(m.width, 640);
  EXPECT_EQ(m.height, 512);
  EXPECT_DOUBLE_EQ(m.K[0], 0.5 * fx);
  EXPECT_DOUBLE_EQ(m.K[2], (640.0 + 0.5) * 0.5 - 0.5);  // the pixel edge at 0 stays at 0
  EXPECT_DOUBLE_EQ(m.P[3], 12.8);
  // Another aspect ratio or an unknown size: refused and unchanged.
  drv::PinholeMatrices other = m;
  EXPECT_FALSE(drv::scalePinhole(other, 640, 480));
  EXPECT_EQ(other.K, m.K);
  drv::PinholeMatrices unknown;
  EXPECT_FALSE(drv::scalePinhole(unknown, 640, 480));
}

TEST(DepthCloud, PointsFromDepthAndColour)
{
  const int w = 4, h = 3;
  std::vector<uint16_t> depth(w * h, 2000);  // 2 m
  depth[1 * w + 2] = 0;                      // no depth
  depth[2 * w + 3] = 1500;
  // Colour at twice the resolution: pixel (2u, 2v) is the one used.
  const int cw = 8, ch = 6;
  std::vector<uint8_t> rgb(cw * ch * 3);
  for (int v = 0; v < ch; ++v)
    for (int u = 0; u < cw; ++u)
    {
      uint8_t* p = &rgb[(v * cw + u) * 3];
      p[0] = static_cast<uint8_t>(10 * u);  // r
      p[1] = static_cast<uint8_t>(10 * v);  // g
      p[2] = 200;                           // b
    }
  const std::array<double, 9> K = {100.0, 0, 1.5, 0, 50.0, 1.0, 0, 0, 1};
  std::vector<Point> out(w * h);
  const drv::DepthImageView dv{reinterpret_cast<const uint8_t*>(depth.data()), w, h, w * sizeof(uint16_t)};
  const drv::RgbImageView cv{rgb.data(), cw, ch, static_cast<size_t>(cw) * 3};
  drv::depthToPoints(dv, &cv, K, kLayout, reinterpret_cast<uint8_t*>(out.data()));

  const Point& p00 = out[0];
  EXPECT_FLOAT_EQ(p00.z, 2.0f);
  EXPECT_FLOAT_EQ(p00.x, -1.5f / 100.0f * 2.0f);
  EXPECT_FLOAT_EQ(p00.y, -1.0f / 50.0f * 2.0f);
  const Point& p23 = out[2 * w + 3];
  EXPECT_FLOAT_EQ(p23.z, 1.5f);
  EXPECT_FLOAT_EQ(p23.x, 1.5f / 100.0f * 1.5f);
  EXPECT_FLOAT_EQ(p23.y, 1.0f / 50.0f * 1.5f);
  EXPECT_EQ(p23.bgra[0], 200);  // b
  EXPECT_EQ(p23.bgra[1], 40);   // g of colour row 4
  EXPECT_EQ(p23.bgra[2], 60);   // r of colour column 6
  const Point& hole = out[1 * w + 2];
  EXPECT_TRUE(std::isnan(hole.x) && std::isnan(hole.y) && std::isnan(hole.z));

  // Without colour: black.
  drv::depthToPoints(dv, nullptr, K, kLayout, reinterpret_cast<uint8_t*>(out.data()));
  EXPECT_EQ(out[2 * w + 3].bgra[0] + out[2 * w + 3].bgra[1] + out[2 * w + 3].bgra[2], 0);
  EXPECT_FLOAT_EQ(out[2 * w + 3].z, 1.5f);
}
