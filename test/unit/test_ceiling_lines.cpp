// Ceiling lines (map/ceiling_lines.h): the ceiling's height measured from the keyframes' horizontal depth lines above
// the camera, and RGB lines on it placed by ray-plane intersection and confirmed from several keyframes. Synthetic,
// against the true edges: noise-free lines on the ceiling are recovered exactly and an edge below it (a wall's, 0.5 m
// lower) is refused; a scene without a plane above the camera, or with too few lines on it, gives no line; the
// plane's height is the depth lines' median.
#include <gtest/gtest.h>

#include "insitu_calibration/map/ceiling_lines.h"

namespace ic = insitu_calibration;

namespace
{
constexpr double kCeiling = 3.0;

// A camera 1.1 m above the floor at (x, y), looking along yaw, tilted 20 degrees up (optical frame: z forward,
// x right, y down).
Eigen::Isometry3d cameraAt(double x, double y, double yaw)
{
  const Eigen::Matrix3d level = (Eigen::Matrix3d() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
               Eigen::AngleAxisd(-20.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix() * level;
  T.translation() = Eigen::Vector3d(x, y, 1.1);
  return T;
}

using Edge = std::pair<Eigen::Vector3d, Eigen::Vector3d>;

// A keyframe that sees `candidates` as RGB segments without usable depth and `measured` as depth lines.
ic::Keyframe keyframeAt(const Eigen::Isometry3d& T, const std::vector<Edge>& candidates,
                        const std::vector<Edge>& measured)
{
  ic::Keyframe kf;
  kf.T_map_camera = T;
  kf.focal_px = 570.0;
  const Eigen::Isometry3d camera_from_map = T.inverse();
  for (const auto& [a, b] : candidates)
  {
    const Eigen::Vector3d ca = camera_from_map * a, cb = camera_from_map * b;
    ic::CeilingObservation obs;
    obs.image = {ca.head<2>() / ca.z(), cb.head<2>() / cb.z()};
    kf.ceiling.push_back(obs);
  }
  for (const auto& [a, b] : measured)
  {
    ic::KeyframeLine line;
    line.line.a = camera_from_map * a;
    line.line.b = camera_from_map * b;
    kf.lines.push_back(line);
  }
  return kf;
}

// The keyframes of a 2 m square path (baseline across every edge) looking along +x.
std::vector<ic::Keyframe> squarePath(const std::vector<Edge>& candidates, const std::vector<Edge>& measured)
{
  std::vector<ic::Keyframe> keyframes;
  for (double s = 0.0; s <= 2.0; s += 0.25)
  {
    keyframes.push_back(keyframeAt(cameraAt(0.0, s - 1.0, 0.0), candidates, measured));
    keyframes.push_back(keyframeAt(cameraAt(s, 1.0, 0.0), candidates, measured));
  }
  return keyframes;
}

double distanceToLine(const Eigen::Vector3d& p, const Edge& e)
{
  const Eigen::Vector3d d = (e.second - e.first).normalized();
  const Eigen::Vector3d r = p - e.first;
  return (r - r.dot(d) * d).norm();
}

// Depth lines on the ceiling elsewhere (they measure its height).
std::vector<Edge> ceilingDepthLines()
{
  return {{{3.0, -1.0, kCeiling}, {3.0, 1.0, kCeiling}}, {{3.5, -1.0, kCeiling}, {3.5, 1.0, kCeiling}}};
}
}  // namespace

TEST(CeilingLines, PlaneHeightIsMeasuredFromHorizontalDepthLinesAboveTheCamera)
{
  // Ceiling lines plus a table's edge (below the camera) and a door frame's post (vertical): only the first count.
  std::vector<Edge> measured = ceilingDepthLines();
  measured.push_back({{4.0, -1.0, 0.46}, {4.0, 1.0, 0.46}});
  measured.push_back({{4.0, 2.0, 0.5}, {4.0, 2.0, 2.5}});
  const auto keyframes = squarePath({}, measured);
  ic::CeilingLineOptions options;
  const auto plane = ic::measureCeilingHeight(keyframes, options, 0.0);
  ASSERT_TRUE(plane.has_value());
  EXPECT_NEAR(plane->height_m, kCeiling, 1e-9);
  EXPECT_EQ(plane->lines, 2 * static_cast<int>(keyframes.size()));
  EXPECT_LT(plane->sigma_m, 1e-9);
  // Too few lines on it: no plane.
  options.min_plane_lines = 2 * static_cast<int>(keyframes.size()) + 1;
  EXPECT_FALSE(ic::measureCeilingHeight(keyframes, options, 0.0).has_value());
}

TEST(CeilingLines, ACabinetTopIsNoCeiling)
{
  // A cabinet's top 1.77 m high, level, 0.67 m above the camera and seen by more depth lines than the ceiling.
  const std::vector<Edge> cabinet = {{{2.5, -0.5, 1.77}, {2.5, 0.5, 1.77}},
                                     {{2.9, -0.5, 1.77}, {2.9, 0.5, 1.77}},
                                     {{2.5, -0.5, 1.77}, {2.9, -0.5, 1.77}}};
  std::vector<Edge> measured = ceilingDepthLines();
  measured.insert(measured.end(), cabinet.begin(), cabinet.end());
  ic::CeilingLineOptions options;
  const auto plane = ic::measureCeilingHeight(squarePath({}, measured), options, 0.0);
  ASSERT_TRUE(plane.has_value());
  EXPECT_NEAR(plane->height_m, kCeiling, 1e-9);
  // Without the ceiling: none, rather than the cabinet.
  EXPECT_FALSE(ic::measureCeilingHeight(squarePath({}, cabinet), options, 0.0).has_value());
  // The limit is above the floor: the same room with its floor 1 m lower in the map finds the cabinet's top 2.77 m
  // above it.
  const auto lower = ic::measureCeilingHeight(squarePath({}, cabinet), options, -1.0);
  ASSERT_TRUE(lower.has_value());
  EXPECT_NEAR(lower->height_m, 1.77, 1e-9);
}

TEST(CeilingLines, ExactCeilingEdgesAreRecoveredAndAnEdgeBelowTheCeilingIsRefused)
{
  const std::vector<Edge> edges = {
      {{6.0, -1.0, kCeiling}, {6.0, 1.0, kCeiling}},  // across the view
      {{5.0, 1.5, kCeiling}, {8.0, 1.5, kCeiling}},   // along it
      {{5.5, -1.5, 2.5}, {5.5, -0.5, 2.5}},           // half a metre below the ceiling (a window's top)
  };
  ic::CeilingLineOptions options;
  options.enabled = true;
  const auto lines = ic::confirmCeilingLines(squarePath(edges, ceilingDepthLines()), {}, {}, options, 0.0);
  ASSERT_EQ(lines.size(), 2u);
  for (const auto& line : lines)
  {
    EXPECT_EQ(line.source, ic::MapLineSource::kCeiling);
    EXPECT_GT(line.sigma(), 0.0);
    EXPECT_LE(line.sigma(), options.lines.max_sigma_m);
    double best = 1e9;
    for (size_t e = 0; e < 2; ++e)
      best = std::min(best, std::max(distanceToLine(line.a(), edges[e]), distanceToLine(line.b(), edges[e])));
    EXPECT_LT(best, 1e-6);
  }
}

TEST(CeilingLines, NoLinesWithoutAPlaneAboveTheCamera)
{
  // The same RGB segments, but no depth line above the camera measures a ceiling: nothing is placed.
  const std::vector<Edge> edges = {{{6.0, -1.0, kCeiling}, {6.0, 1.0, kCeiling}}};
  ic::CeilingLineOptions options;
  options.enabled = true;
  EXPECT_TRUE(ic::confirmCeilingLines(squarePath(edges, {}), {}, {}, options, 0.0).empty());
  // A scene without any line: none.
  EXPECT_TRUE(ic::confirmCeilingLines(squarePath({}, {}), {}, {}, options, 0.0).empty());
  // A depth line that already holds the edge: not made again.
  ic::MapLine depth;
  depth.point = edges[0].first;
  depth.direction = (edges[0].second - edges[0].first).normalized();
  depth.s_max = 2.0;
  EXPECT_TRUE(ic::confirmCeilingLines(squarePath(edges, ceilingDepthLines()), {}, {depth}, options, 0.0).empty());
}
