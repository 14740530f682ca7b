// The measured surfaces that hide map lines from a fixed camera (map/surface_voxels.h), against geometry known
// exactly: a wall between the camera and a line hides it, a line on the wall seen at a grazing angle stays visible,
// a line partly behind the wall is cut where the wall's edge predicts, a column's near faces hide its far edge.
#include <gtest/gtest.h>

#include "insitu_calibration/map/surface_voxels.h"

namespace ic = insitu_calibration;

namespace
{
// A wall in the plane x = x0, y within [y0, y1], z within [0, 3], measured from a sensor on the side x < x0 (the
// layer 1.5 voxels deep lies behind it, as insertDepth puts it).
void insertWallX(ic::SurfaceVoxels& voxels, double x0, double y0, double y1)
{
  for (double y = y0; y <= y1; y += 0.02)
    for (double z = 0.0; z <= 3.0; z += 0.02)
    {
      for (int k = 0; k < 4; ++k)
        voxels.insert({x0 + 0.5 * k * voxels.options().voxel_m, y, z});
    }
}

// A wall in the plane y = 0, x within [0, 20], measured from the side y > 0.
void insertWallY(ic::SurfaceVoxels& voxels)
{
  for (double x = 0.0; x <= 20.0; x += 0.02)
    for (double z = 0.0; z <= 3.0; z += 0.02)
    {
      for (int k = 0; k < 4; ++k)
        voxels.insert({x, -0.5 * k * voxels.options().voxel_m, z});
    }
}
// A 64 x 48 camera (f 500 px) facing a plane at depth_m.
ic::RgbdFrame planeAt(double depth_m)
{
  ic::RgbdFrame frame;
  frame.camera.width = 64;
  frame.camera.height = 48;
  frame.camera.intrinsics.fx = frame.camera.intrinsics.fy = 500.0;
  frame.camera.intrinsics.cx = 31.5;
  frame.camera.intrinsics.cy = 23.5;
  frame.depth = cv::Mat(48, 64, CV_32FC1, cv::Scalar(static_cast<float>(depth_m)));
  return frame;
}
}  // namespace

TEST(SurfaceVoxels, DepthOfAPlaneMarksTwoVoxelLayers)
{
  ic::SurfaceVoxels voxels;
  ic::RgbdFrame frame = planeAt(3.0);  // 2.4 cm between samples at 3 m
  frame.depth.at<float>(0, 0) = 0.0f;  // no measurement
  voxels.insertDepth(frame);
  EXPECT_TRUE(voxels.occupied({0.18, 0.13, 3.01}));  // the image corner's sample (col 62, row 46)
  EXPECT_TRUE(voxels.occupied({0.01, 0.01, 3.01}));
  EXPECT_TRUE(voxels.occupied({0.01, 0.01, 3.06}));  // the layer behind
  EXPECT_FALSE(voxels.occupied({0.01, 0.01, 2.9}));
  EXPECT_FALSE(voxels.occupied({0.01, 0.01, 3.2}));

  frame.depth.setTo(cv::Scalar(9.0f));  // beyond max_range_m: not inserted
  ic::SurfaceVoxels far;
  far.insertDepth(frame);
  EXPECT_EQ(far.size(), 0u);
}

TEST(SurfaceVoxels, AWallHidesWhatIsBehindItOnly)
{
  ic::SurfaceVoxels voxels;
  insertWallX(voxels, 2.0, -1.0, 1.0);
  const Eigen::Vector3d camera(0.0, 0.0, 1.5);
  EXPECT_TRUE(voxels.blocks(camera, {4.0, 0.0, 1.5}));
  EXPECT_TRUE(voxels.blocks(camera, {6.0, 0.5, 1.0}));
  EXPECT_FALSE(voxels.blocks(camera, {1.5, 0.0, 1.5}));  // in front of the wall
  EXPECT_FALSE(voxels.blocks(camera, {4.0, 3.0, 1.5}));  // past the wall's end
  EXPECT_FALSE(voxels.blocks(camera, {2.0, 0.3, 1.5}));  // on the wall: its own surface does not hide it
}

TEST(SurfaceVoxels, ALineOnAWallSeenAtAGrazingAngleStaysVisible)
{
  ic::SurfaceVoxels voxels;
  insertWallY(voxels);
  const Eigen::Vector3d camera(0.0, 0.5, 2.5);  // 0.5 m from the wall, looking along it
  for (const double x : {2.0, 5.0, 10.0, 15.0})
    EXPECT_FALSE(voxels.blocks(camera, {x, 0.0, 1.0})) << "x " << x;
  EXPECT_TRUE(voxels.blocks(camera, {10.0, -1.0, 1.0}));  // behind the wall
}

TEST(SurfaceVoxels, ALinePartlyBehindAWallIsCutWhereTheWallEnds)
{
  ic::SurfaceVoxels voxels;
  insertWallX(voxels, 2.0, -1.0, 1.0);
  const Eigen::Vector3d camera(0.0, 0.0, 1.5);
  // The line x = 4 from y = -3 to 3: a sight line crosses x = 2 at y / 2, so |y| < 2 is hidden.
  const auto parts = voxels.unoccludedParts(camera, {{{4.0, -3.0, 1.5}, {4.0, 3.0, 1.5}}});
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_NEAR(parts[0].a.y(), -3.0, 1e-9);
  EXPECT_NEAR(parts[0].b.y(), -2.0, 0.15);
  EXPECT_NEAR(parts[1].a.y(), 2.0, 0.15);
  EXPECT_NEAR(parts[1].b.y(), 3.0, 1e-9);

  const ic::SurfaceVoxels empty;  // nothing measured: nothing hidden
  const auto all = empty.unoccludedParts(camera, {{{4.0, -3.0, 1.5}, {4.0, 3.0, 1.5}}});
  ASSERT_EQ(all.size(), 1u);
  EXPECT_NEAR((all[0].a - Eigen::Vector3d(4.0, -3.0, 1.5)).norm(), 0.0, 1e-9);
  EXPECT_NEAR((all[0].b - Eigen::Vector3d(4.0, 3.0, 1.5)).norm(), 0.0, 1e-9);
}

// A column 0.6 m square (x 5-5.6, y -0.3-0.3, z 0-3; the generated buildings' largest) on a floor (z = 0, x 0-20,
// y -5-5), every face measured with its layer behind it (inside the column, below the floor).
ic::SurfaceVoxels columnOnAFloor(const ic::SurfaceVoxelOptions& options)
{
  ic::SurfaceVoxels voxels(options);
  const double layer = 0.5 * options.voxel_m;
  for (double x = 0.0; x <= 20.0; x += 0.02)
    for (double y = -5.0; y <= 5.0; y += 0.02)
      for (int k = 0; k < 4; ++k)
        voxels.insert({x, y, -k * layer});
  for (double t = 0.0; t <= 0.6; t += 0.01)
    for (double z = 0.0; z <= 3.0; z += 0.01)
      for (int k = 0; k < 4; ++k)
      {
        voxels.insert({5.0 + k * layer, -0.3 + t, z});  // front
        voxels.insert({5.6 - k * layer, -0.3 + t, z});  // back
        voxels.insert({5.0 + t, -0.3 + k * layer, z});  // sides
        voxels.insert({5.0 + t, 0.3 - k * layer, z});
      }
  return voxels;
}

TEST(SurfaceVoxels, AColumnsNearFacesHideItsFarEdge)
{
  const ic::SurfaceVoxels voxels = columnOnAFloor({});
  const Eigen::Vector3d camera(0.0, -2.0, 3.0);  // sees the faces x = 5 and y = -0.3
  const Eigen::Vector3d vertical = Eigen::Vector3d::UnitZ(), along_x = Eigen::Vector3d::UnitX(),
                        along_y = Eigen::Vector3d::UnitY();
  // The far vertical edge: its sight lines cross the near face (at y = 0.05) 0.6 m before it, within the target's
  // margin (0.3 m + 0.08 of 6.2 m), and the way from there across to the edge crosses the column's empty inside.
  EXPECT_TRUE(voxels.blocks(camera, {5.6, 0.3, 1.5}, vertical));
  EXPECT_TRUE(voxels.blocks(camera, {5.8, 0.4, 0.0}, along_y));  // a floor line just behind it
  // The edges it shows, and the floor in front of it, beside it and far beyond it.
  EXPECT_FALSE(voxels.blocks(camera, {5.0, 0.3, 1.5}, vertical));
  EXPECT_FALSE(voxels.blocks(camera, {5.6, -0.3, 1.5}, vertical));
  EXPECT_FALSE(voxels.blocks(camera, {5.0, -0.3, 0.5}, vertical));
  EXPECT_FALSE(voxels.blocks(camera, {4.8, 0.0, 0.0}, along_x));
  EXPECT_FALSE(voxels.blocks(camera, {5.3, -0.8, 0.0}, along_x));
  for (const double x : {3.0, 8.0, 15.0, 19.0})  // the floor the sight lines graze, clear of the column
  {
    EXPECT_FALSE(voxels.blocks(camera, {x, -3.0, 0.0}, along_x)) << "x " << x;
    EXPECT_FALSE(voxels.blocks(camera, {x, -3.0, 0.0}, along_y)) << "x " << x;
  }
  // The far edge as a line: hidden up to where it shows above the column's top (z > 2.9 there).
  const auto parts = voxels.unoccludedParts(camera, {{{5.6, 0.3, 0.0}, {5.6, 0.3, 3.0}}});
  EXPECT_TRUE(parts.empty() || parts.front().a.z() > 2.5);
  // Without a line's direction, or with the test of other surfaces off, the margin keeps the far edge, as before.
  EXPECT_FALSE(voxels.blocks(camera, {5.6, 0.3, 1.5}));
  ic::SurfaceVoxelOptions margin_only;
  margin_only.other_surface_margin_m = 0.0;
  EXPECT_FALSE(columnOnAFloor(margin_only).blocks(camera, {5.6, 0.3, 1.5}, vertical));
}

TEST(DepthRangeGrid, HoldsTheNearestAndFarthestDepthPerCell)
{
  ic::RgbdFrame frame = planeAt(3.0);
  frame.depth(cv::Rect(0, 0, 16, 16)).setTo(cv::Scalar(1.5f));    // something nearer at the top left
  frame.depth(cv::Rect(48, 32, 16, 16)).setTo(cv::Scalar(0.0f));  // no depth at the bottom right
  frame.depth.at<float>(24, 40) = 2.0f;                           // one nearer pixel right of the centre
  const ic::DepthRangeGrid grid = ic::depthRangeGrid(frame, 16.0, 1);
  auto at = [&](double col, double row) { return grid.nearestAt(frame.camera.normalize({col, row})); };
  EXPECT_FLOAT_EQ(at(8.0, 8.0), 1.5f);
  EXPECT_FLOAT_EQ(at(20.0, 24.0), 3.0f);
  EXPECT_FLOAT_EQ(at(40.0, 20.0), 2.0f);       // the cell holding (40, 24)
  EXPECT_EQ(at(56.0, 40.0), 0.0);              // no depth: no evidence
  EXPECT_EQ(grid.nearestAt({5.0, 0.0}), 0.0);  // outside the view
  EXPECT_FLOAT_EQ(grid.farthestAt(frame.camera.normalize({8.0, 8.0})), 1.5f);
  EXPECT_FLOAT_EQ(grid.farthestAt(frame.camera.normalize({40.0, 20.0})), 3.0f);
  frame.depth.at<float>(20, 40) = 0.0f;  // a pixel without depth: what the cell hides is unknown
  EXPECT_EQ(ic::depthRangeGrid(frame, 16.0, 1).farthestAt(frame.camera.normalize({40.0, 20.0})), 0.0);
}
