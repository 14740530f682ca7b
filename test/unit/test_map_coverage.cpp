// Map coverage (lines/line_evaluation.h, issue 11): the share of a camera's image lines, by length, on a true edge the
// map holds within 1 cm. Synthetic: two true edges of equal image length seen by a distorted camera, image lines drawn
// exactly on them (and one on no edge); the map holds one edge, the other exactly, 5 mm or 2 cm off; on a long edge
// only a map line where the image line shows it counts.
#include <gtest/gtest.h>

#include "insitu_calibration/lines/line_evaluation.h"

namespace ic = insitu_calibration;

namespace
{
// 640 x 480, barrel distortion, at the origin looking along +z (the map frame is the camera frame).
ic::CameraModel camera()
{
  ic::Intrinsics k;
  k.fx = k.fy = 500.0;
  k.cx = 319.5;
  k.cy = 239.5;
  ic::DivisionModel distortion;
  distortion.center = k.principalPoint();
  distortion.lambda = ic::lambdaForCornerDisplacement(distortion.center, 640, 480, -8.0);
  return ic::CameraModel(k, distortion, ic::CameraPose());
}

// The segment's distorted image as a polyline of 20 points.
std::vector<Eigen::Vector2d> imageOf(const ic::CameraModel& cam, const ic::Segment3d& s)
{
  std::vector<Eigen::Vector2d> polyline;
  for (int i = 0; i < 20; ++i)
    polyline.push_back(*cam.project(s.a + (s.b - s.a) * (i / 19.0)));
  return polyline;
}

ic::Segment3d shifted(const ic::Segment3d& s, const Eigen::Vector3d& by)
{
  return {s.a + by, s.b + by};
}

// Two horizontal edges 5 m ahead, 1 m long, above and below the view's centre: the same image length.
const std::vector<ic::Segment3d> kEdges = {{{-0.5, -0.8, 5.0}, {0.5, -0.8, 5.0}}, {{-0.5, 0.8, 5.0}, {0.5, 0.8, 5.0}}};
}  // namespace

TEST(MapCoverage, CountsTheImageLengthOnTrueEdgesTheMapHoldsWithinOneCentimetre)
{
  const ic::CameraModel cam = camera();
  const std::vector<std::vector<Eigen::Vector2d>> lines = {imageOf(cam, kEdges[0]), imageOf(cam, kEdges[1])};

  const ic::MapCoverage half = ic::measureMapCoverage(lines, cam, kEdges, {kEdges[0]});
  EXPECT_NEAR(half.fraction(), 0.5, 1e-3);
  EXPECT_EQ(half.covered_lines, 1u);
  EXPECT_NEAR(half.on_edge_px, half.total_px, 1e-9);
  // Per line: its edge, whether the map holds it and the part of the edge it shows (here all of it).
  ASSERT_EQ(half.details.size(), 2u);
  EXPECT_TRUE(half.details[0].covered);
  EXPECT_FALSE(half.details[1].covered);
  EXPECT_GE(half.details[1].edge, 0);
  EXPECT_LT((half.details[1].shown.a - kEdges[1].a).norm() + (half.details[1].shown.b - kEdges[1].b).norm(), 0.02);

  // A map line 5 mm off its edge counts; 2 cm off does not (across the view or along it, towards the camera).
  EXPECT_NEAR(ic::measureMapCoverage(lines, cam, kEdges, {kEdges[0], shifted(kEdges[1], {0, 0.005, 0})}).fraction(),
              1.0, 1e-9);
  EXPECT_NEAR(ic::measureMapCoverage(lines, cam, kEdges, {kEdges[0], shifted(kEdges[1], {0, 0.02, 0})}).fraction(), 0.5,
              1e-3);
  EXPECT_NEAR(ic::measureMapCoverage(lines, cam, kEdges, {kEdges[0], shifted(kEdges[1], {0, 0, -0.02})}).fraction(),
              0.5, 1e-3);
  // A map line on the edge's line but beyond its extent holds nothing of it.
  EXPECT_NEAR(ic::measureMapCoverage(lines, cam, kEdges, {kEdges[0], shifted(kEdges[1], {2.0, 0, 0})}).fraction(), 0.5,
              1e-3);
}

TEST(MapCoverage, AMapLineOnALongEdgeCountsWhereTheImageLineShowsIt)
{
  // The first edge goes on for 10 m to the side, out of the view; the image line shows its first metre.
  const ic::CameraModel cam = camera();
  const std::vector<ic::Segment3d> edges = {{kEdges[0].a, {10.5, -0.8, 5.0}}};
  const std::vector<std::vector<Eigen::Vector2d>> lines = {imageOf(cam, kEdges[0])};
  EXPECT_EQ(ic::measureMapCoverage(lines, cam, edges, {{{5.0, -0.8, 5.0}, {6.0, -0.8, 5.0}}}).fraction(), 0.0);
  EXPECT_NEAR(ic::measureMapCoverage(lines, cam, edges, {{{0.3, -0.8, 5.0}, {2.0, -0.8, 5.0}}}).fraction(), 1.0, 1e-9);
}

TEST(MapCoverage, AnImageLineOnNoTrueEdgeCountsAsUncovered)
{
  const ic::CameraModel cam = camera();
  const ic::Segment3d nowhere{{-0.5, 0.0, 5.0}, {0.5, 0.0, 5.0}};  // the same image length, no true edge there
  const std::vector<std::vector<Eigen::Vector2d>> lines = {imageOf(cam, kEdges[0]), imageOf(cam, kEdges[1]),
                                                           imageOf(cam, nowhere)};
  const ic::MapCoverage coverage = ic::measureMapCoverage(lines, cam, kEdges, kEdges);
  EXPECT_EQ(coverage.lines, 3u);
  EXPECT_EQ(coverage.covered_lines, 2u);
  EXPECT_NEAR(coverage.on_edge_px, coverage.covered_px, 1e-9);
  // The middle line is straight (through the distortion centre), the others curve: about two thirds.
  EXPECT_NEAR(coverage.fraction(), 2.0 / 3.0, 0.01);
  EXPECT_EQ(ic::measureMapCoverage({}, cam, kEdges, kEdges).fraction(), 0.0);
}
