// Map lines that are one flank of a joint a fixed camera does not resolve (map/joint_lines.h): a joint's two flanks
// 1 cm apart are one ridge from 10 m and two edges from 2 m; a floor joint seen at a grazing angle is one ridge
// even from 3 m; lines that are not twins (turned, too far apart, beside each other end to end) keep their sigma.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "insitu_calibration/map/joint_lines.h"

namespace ic = insitu_calibration;

namespace
{
constexpr double kSigma = 0.001;
constexpr double kFocal = 1000.0;

ic::Segment3d horizontal(double y, double z, double x0 = -1.0, double x1 = 1.0)
{
  return {Eigen::Vector3d(x0, y, z), Eigen::Vector3d(x1, y, z)};
}

std::vector<double> sigmasOf(const std::vector<ic::Segment3d>& lines, const Eigen::Vector3d& viewpoint,
                             const ic::UnresolvedJointOptions& options = {})
{
  return ic::unresolvedJointSigmas(lines, std::vector<double>(lines.size(), kSigma), viewpoint, kFocal, options);
}
}  // namespace

TEST(UnresolvedJoints, AMortarJointIsOneRidgeFromAfarAndTwoEdgesFromNear)
{
  // A wall at y = 0; a 1 cm mortar joint's flanks at z = 1.00 and 1.01; an edge 10 cm below.
  const std::vector<ic::Segment3d> wall = {horizontal(0.0, 1.0), horizontal(0.0, 1.01), horizontal(0.0, 0.9)};
  const auto far = sigmasOf(wall, Eigen::Vector3d(0.0, -10.0, 1.0));  // 1 cm = 1 px across
  EXPECT_NEAR(far[0], std::hypot(kSigma, 0.005), 1e-12);
  EXPECT_NEAR(far[1], std::hypot(kSigma, 0.005), 1e-12);
  EXPECT_EQ(far[2], kSigma);                                          // 10 cm is a separate edge
  const auto near = sigmasOf(wall, Eigen::Vector3d(0.0, -2.0, 1.0));  // 5 px across: resolved
  for (const double s : near)
    EXPECT_EQ(s, kSigma);
}

TEST(UnresolvedJoints, AFloorJointAtAGrazingAngleIsOneRidge)
{
  // Floor joints along x at y = 0 and 0.01, seen from 3 m away along y at 0.3 m height (0.33 px across), against
  // the same joint on a wall facing the camera at the same range (3.3 px across).
  const std::vector<ic::Segment3d> floor = {horizontal(0.0, 0.0), horizontal(0.01, 0.0)};
  const auto grazing = sigmasOf(floor, Eigen::Vector3d(0.0, -3.0, 0.3));
  EXPECT_GT(grazing[0], 4.0 * kSigma);
  EXPECT_GT(grazing[1], 4.0 * kSigma);
  const std::vector<ic::Segment3d> wall = {horizontal(0.0, 1.0), horizontal(0.0, 1.01)};
  for (const double s : sigmasOf(wall, Eigen::Vector3d(0.0, -3.0, 1.0)))
    EXPECT_EQ(s, kSigma);
}

TEST(UnresolvedJoints, LinesThatAreNotTwinsKeepTheirSigma)
{
  const Eigen::Vector3d far(0.0, -10.0, 1.0);
  const ic::Segment3d base = horizontal(0.0, 1.0);
  ic::Segment3d turned = horizontal(0.0, 1.01);
  turned.b.z() += 2.0 * std::tan(5.0 * M_PI / 180.0);  // 5 deg
  const std::vector<std::vector<ic::Segment3d>> pairs = {
      {base, turned},
      {base, horizontal(0.0, 1.04)},            // 4 cm apart: wider than a joint
      {base, horizontal(0.0, 1.01, 1.5, 3.0)},  // beside it, not along it
      {base, horizontal(0.0, 1.0, 0.5, 2.0)}};  // collinear, overlapping: no width
  for (const auto& pair : pairs)
    for (const double s : sigmasOf(pair, far))
      EXPECT_EQ(s, kSigma);
  // Off, or sigmas that do not match the lines (one for two): unchanged.
  ic::UnresolvedJointOptions off;
  off.enabled = false;
  const std::vector<ic::Segment3d> joint = {base, horizontal(0.0, 1.01)};
  for (const double s : sigmasOf(joint, far, off))
    EXPECT_EQ(s, kSigma);
  EXPECT_EQ(ic::unresolvedJointSigmas(joint, {kSigma}, far, kFocal), std::vector<double>{kSigma});
}

TEST(UnresolvedJoints, AShortFlankBesideALongTiltedOneIsATwinEitherWay)
{
  // A 0.5 m line at z = 1 and a 4 m line 5 mm above it, turned 0.7 deg: beside each other they are a 5 mm joint
  // (1 px at 5 m), whichever is measured from which; far from the short one the long one drifts 2.4 cm away.
  const ic::Segment3d short_line{Eigen::Vector3d(-0.25, 0.0, 1.0), Eigen::Vector3d(0.25, 0.0, 1.0)};
  const double slope = std::tan(0.7 * M_PI / 180.0);
  const ic::Segment3d long_line{Eigen::Vector3d(-0.25, 0.0, 1.005), Eigen::Vector3d(3.75, 0.0, 1.005 + 4.0 * slope)};
  for (const auto& lines :
       {std::vector<ic::Segment3d>{short_line, long_line}, std::vector<ic::Segment3d>{long_line, short_line}})
  {
    const auto s = sigmasOf(lines, Eigen::Vector3d(0.0, -5.0, 1.0));
    EXPECT_GT(s[0], kSigma);
    EXPECT_GT(s[1], kSigma);
    EXPECT_LT(s[0], std::hypot(kSigma, 0.005));  // at most half the joint near the short line
  }
}

TEST(UnresolvedJoints, TheWidestUnresolvedTwinSetsTheSigma)
{
  // Three flanks 1 cm and 2.5 cm above a line, 20 m away at 1000 px: all within 1.25 px, one ridge 2.5 cm wide.
  const std::vector<ic::Segment3d> lines = {horizontal(0.0, 1.0), horizontal(0.0, 1.01), horizontal(0.0, 1.025)};
  const auto s = sigmasOf(lines, Eigen::Vector3d(0.0, -20.0, 1.0));
  EXPECT_NEAR(s[0], std::hypot(kSigma, 0.0125), 1e-12);
  EXPECT_NEAR(s[2], std::hypot(kSigma, 0.0125), 1e-12);
  EXPECT_NEAR(s[1], std::hypot(kSigma, 0.0075), 1e-12);  // its farthest twin is 1.5 cm away
}

TEST(UnresolvedJoints, DegenerateInputKeepsItsSigmaOrGetsZero)
{
  const Eigen::Vector3d far(0.0, -10.0, 1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const ic::Segment3d joint_a = horizontal(0.0, 1.0), joint_b = horizontal(0.0, 1.01);
  const std::vector<ic::Segment3d> lines = {joint_a,
                                            joint_b,
                                            {Eigen::Vector3d(nan, 0, 1), Eigen::Vector3d(1, 0, 1)},   // NaN
                                            {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, 1)},     // a point
                                            {Eigen::Vector3d(0, -5, 1), Eigen::Vector3d(0, -4, 1)}};  // end on
  const auto s = sigmasOf(lines, far);
  EXPECT_GT(s[0], kSigma);
  EXPECT_GT(s[1], kSigma);
  for (size_t i = 2; i < lines.size(); ++i)
    EXPECT_EQ(s[i], kSigma) << i;
  // No focal length: unchanged. No sigmas: 0 for each line, the joints grown from it.
  EXPECT_EQ(ic::unresolvedJointSigmas(lines, std::vector<double>(lines.size(), kSigma), far, 0.0),
            std::vector<double>(lines.size(), kSigma));
  const auto from_zero = ic::unresolvedJointSigmas({joint_a, joint_b, horizontal(0.0, 0.5)}, {}, far, kFocal);
  ASSERT_EQ(from_zero.size(), 3u);
  EXPECT_NEAR(from_zero[0], 0.005, 1e-12);
  EXPECT_EQ(from_zero[2], 0.0);
}

// Texture lines (textureLines): a brick wall's bed joints (two flanks 1 cm apart every 6.5 cm) are texture, all but
// the field's outermost flanks; an edge above the field, a door frame's few parallel edges, a lone edge and an
// edge mapped twice (two lines 2 mm apart) are not; off with min_neighbours 0.
TEST(TextureLines, BrickJointsAreTextureStructuralEdgesAreNot)
{
  std::vector<ic::Segment3d> lines;
  for (int course = 0; course < 8; ++course)
    for (const double flank : {0.0, 0.01})
      lines.push_back(horizontal(3.0, 0.5 + 0.065 * course + flank));
  const size_t bricks = lines.size();
  lines.push_back(horizontal(3.0, 0.5 + 0.065 * 7 + 0.2));  // an edge above the brick field: not one of its joints
  for (const double x : {-2.0, -1.96, -1.92})               // a door frame: three vertical edges 4 cm apart
    lines.push_back({Eigen::Vector3d(x, 3.0, 0.0), Eigen::Vector3d(x, 3.0, 2.0)});
  lines.push_back(horizontal(-2.0, 2.5));  // a lone edge, mapped twice 2 mm apart
  lines.push_back(horizontal(-2.0, 2.502));
  const std::vector<bool> texture = ic::textureLines(lines);
  ASSERT_EQ(texture.size(), lines.size());
  // The field's two lowest flanks have fewer than two neighbours below them, its top one (the edge above counts)
  // fewer than two above it.
  for (size_t i = 0; i < lines.size(); ++i)
    EXPECT_EQ(texture[i], i >= 2 && i + 1 < bricks) << "line " << i;

  ic::TextureLineOptions off;
  off.min_neighbours = 0;
  for (const bool t : ic::textureLines(lines, off))
    EXPECT_FALSE(t);
  ic::TextureLineOptions two;  // the door frame's edges have two neighbours each
  two.min_neighbours = 2;
  EXPECT_TRUE(ic::textureLines(lines, two)[bricks + 2]);  // the frame's middle edge
  EXPECT_FALSE(ic::textureLines(lines, two).back());
}

// Lines beside each other end to end, or crossing, are not beside each other (besideSeparation).
TEST(TextureLines, BesideSeparationNeedsOverlapAndParallelLines)
{
  const double cos_max = std::cos(3.0 * M_PI / 180.0);
  const auto s = ic::besideSeparation(horizontal(0.0, 1.0), horizontal(0.0, 1.1), cos_max, 0.3);
  ASSERT_TRUE(s.has_value());
  EXPECT_NEAR(s->z(), 0.1, 1e-12);
  EXPECT_NEAR(s->head<2>().norm(), 0.0, 1e-12);
  EXPECT_FALSE(ic::besideSeparation(horizontal(0.0, 1.0, -1.0, 0.0), horizontal(0.0, 1.1, 0.1, 1.0), cos_max, 0.3));
  const ic::Segment3d across{Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(0.0, 0.0, 2.0)};
  EXPECT_FALSE(ic::besideSeparation(horizontal(0.0, 1.0), across, cos_max, 0.3));
}
