// Edge sightings (simulation/edge_sightings.h, issue 11's coverage diagnosis): how often the survey's Xtion saw a true
// edge, in view and with depth. Against the geometry: a wall's edge 2 m ahead is in view with depth; 7 m ahead in view
// without depth (beyond the 5 m range); behind the camera, or hidden behind a panel, never in view; and from no
// keyframe nothing.
#include <gtest/gtest.h>

#include "insitu_calibration/simulation/edge_sightings.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
// A wall facing the origin at x = d (a 1 x 1 m square, so that its bottom edge at z = -0.3 is a true edge), and
// optionally a panel between at x = panel covering that edge.
sim::World wallWorld(double d, double panel = 0.0)
{
  std::string text = "route: {waypoints: [[0, 0], [1, 0]]}\nsurfaces:\n  - name: wall\n    rectangle: {center: [" +
                     std::to_string(d) +
                     ", 0, 0.2], normal: [-1, 0, 0], size: [1, 1]}\n    texture: {color: [200, 200, 200]}\n";
  if (panel > 0.0)
    text += "  - name: panel\n    rectangle: {center: [" + std::to_string(panel) +
            ", 0, -0.3], normal: [-1, 0, 0], size: [2, 1]}\n    texture: {color: [90, 90, 90]}\n";
  text += "fixed_cameras: []\n";
  auto world = sim::parseWorld(text, "sightings.yaml");
  EXPECT_TRUE(world) << world.error().describe();
  return world ? std::move(*world) : sim::World{};
}

// The Xtion's optical frame at the origin looking along yaw (optical z forward, y down).
Eigen::Isometry3d lookingAlong(double yaw)
{
  const Eigen::Matrix3d level = (Eigen::Matrix3d() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * level;
  return T;
}

ic::Segment3d bottomEdge(double d)
{
  return {{d, -0.4, -0.3}, {d, 0.4, -0.3}};
}
}  // namespace

TEST(EdgeSightings, InViewWithDepthNearAndWithoutBeyondTheRange)
{
  const std::vector<Eigen::Isometry3d> poses = {lookingAlong(0.0), lookingAlong(0.0), lookingAlong(M_PI)};
  const auto near = sim::sightSegments(wallWorld(2.0), {bottomEdge(2.0)}, poses);
  ASSERT_EQ(near.size(), 1u);
  EXPECT_EQ(near[0].in_view, 2);  // the third keyframe looks away
  EXPECT_EQ(near[0].with_depth, 2);
  EXPECT_NEAR(near[0].nearest_range_m, 2.0, 0.02);
  const auto far = sim::sightSegments(wallWorld(7.0), {bottomEdge(7.0)}, poses);
  EXPECT_EQ(far[0].in_view, 2);
  EXPECT_EQ(far[0].with_depth, 0);  // beyond the Xtion's 5 m
}

TEST(EdgeSightings, HiddenOrUnseenEdgesAreNeverInView)
{
  const std::vector<Eigen::Isometry3d> poses = {lookingAlong(0.0)};
  // A panel 1 m ahead hides the wall's bottom edge.
  const auto hidden = sim::sightSegments(wallWorld(3.0, 1.0), {bottomEdge(3.0)}, poses);
  EXPECT_EQ(hidden[0].in_view, 0);
  EXPECT_TRUE(std::isinf(hidden[0].nearest_range_m));
  // No keyframe: no sighting.
  const auto none = sim::sightSegments(wallWorld(2.0), {bottomEdge(2.0)}, {});
  EXPECT_EQ(none[0].in_view, 0);
  EXPECT_EQ(none[0].with_depth, 0);
}
