// Floor lines (map/floor_lines.h): RGB lines placed on the floor plane by ray-plane intersection and confirmed from
// several keyframes. Synthetic: exact floor edges are recovered, an edge above the floor is refused by the views'
// disagreement, the predicted error grows with the range, depth that disagrees with the floor refuses a segment.
// Simulated: config/worlds/floor_hall.yaml (a tiled floor, walls 5.5 m and more from the route, the Xtion tilted
// down) surveyed with a perfect localiser: floor map lines beyond the depth range exist, lie within 3 predicted
// sigmas of a true floor edge (none on an edge off the floor), and the share of a fixed camera's true floor edges
// that the map holds rises. The simulated seed (4) was not used while tuning (1 and 2 were).
#include <gtest/gtest.h>

#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/map/floor_lines.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/survey/survey.h"
#include "insitu_calibration/test_support/simulated_survey.h"
#include "insitu_calibration/test_support/test_helpers.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const std::string kSource = INSITU_SOURCE_DIR;

// A camera 1.1 m above the floor at (x, y), looking along yaw, tilted 15 degrees down.
Eigen::Isometry3d cameraAt(double x, double y, double yaw)
{
  return ic::test::tiltedCameraPose(x, y, yaw, 15.0, 1.1);
}

// The segment's image in normalised coordinates (both ends in front of the camera).
ic::FloorObservation observe(const Eigen::Isometry3d& T_map_camera, const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  const Eigen::Vector3d ca = T_map_camera.inverse() * a, cb = T_map_camera.inverse() * b;
  return {ca.head<2>() / ca.z(), cb.head<2>() / cb.z()};
}

ic::Keyframe keyframeAt(const Eigen::Isometry3d& T,
                        const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>& edges)
{
  ic::Keyframe kf;
  kf.T_map_camera = T;
  kf.focal_px = 570.0;
  for (const auto& [a, b] : edges)
    kf.floor.push_back(observe(T, a, b));
  return kf;
}

// On the floor: both ends at z = 0 (the floor's texture edges, the walls' and boxes' bases).
bool onFloor(const sim::TrueEdge& e)
{
  return std::abs(e.start.z()) < 1e-3 && std::abs(e.end.z()) < 1e-3;
}

double distanceToLine(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  const Eigen::Vector3d d = (b - a).normalized();
  const Eigen::Vector3d r = p - a;
  return (r - r.dot(d) * d).norm();
}
}  // namespace

TEST(FloorLines, ExactFloorEdgesAreRecoveredAndAnEdgeAboveTheFloorIsRefused)
{
  // Two floor edges 8 m ahead (across and along the view) and an edge 0.5 m above the floor, seen from keyframes on
  // a 2 m square path (baseline across every edge).
  const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> edges = {
      {{9.0, -1.0, 0.0}, {9.0, 1.0, 0.0}},   // across
      {{7.0, 1.5, 0.0}, {10.0, 1.5, 0.0}},   // along
      {{8.0, -1.5, 0.5}, {8.0, -0.5, 0.5}},  // above the floor
  };
  std::vector<ic::Keyframe> keyframes;
  for (double s = 0.0; s <= 2.0; s += 0.25)
  {
    keyframes.push_back(keyframeAt(cameraAt(0.0, s - 1.0, 0.0), edges));
    keyframes.push_back(keyframeAt(cameraAt(s, 1.0, 0.0), edges));
  }
  ic::FloorLineOptions options;
  options.enabled = true;
  const auto lines = ic::confirmFloorLines(keyframes, {}, {}, options);
  ASSERT_EQ(lines.size(), 2u);
  for (const auto& line : lines)
  {
    EXPECT_EQ(line.source, ic::MapLineSource::kFloor);
    EXPECT_GT(line.sigma(), 0.0);
    double best = 1e9;
    for (size_t e = 0; e < 2; ++e)
      best = std::min(best, std::max(distanceToLine(line.a(), edges[e].first, edges[e].second),
                                     distanceToLine(line.b(), edges[e].first, edges[e].second)));
    EXPECT_LT(best, 1e-6);
  }
  // The edge above the floor alone, seen from one viewpoint only (no baseline): not confirmed either.
  std::vector<ic::Keyframe> still(3, keyframeAt(cameraAt(0.0, 0.0, 0.0), {edges[0]}));
  EXPECT_TRUE(ic::confirmFloorLines(still, {}, {}, options).empty());
}

TEST(FloorLines, PredictedErrorGrowsWithRange)
{
  ic::FloorLineOptions options;
  const Eigen::Isometry3d T = cameraAt(0.0, 0.0, 0.0);
  double previous = 0.0;
  for (const double x : {3.0, 6.0, 9.0, 11.5})
  {
    ic::FloorCandidate c;
    ASSERT_TRUE(ic::intersectFloor(observe(T, {x, -1.0, 0.0}, {x, 1.0, 0.0}), T, 570.0, options, &c));
    EXPECT_NEAR(c.a.x(), x, 1e-9);
    const double sigma = std::hypot(c.sigma_random_m, c.sigma_systematic_m);
    // The grazing angle: at least quadratic in the range (over 1.1 m of height).
    EXPECT_GT(sigma, 0.9 * (x * x + 1.21) / 1.1 * options.pixel_sigma_px / 570.0);
    EXPECT_GT(sigma, previous * 1.5);
    previous = sigma;
  }
  ic::FloorCandidate c;
  EXPECT_FALSE(ic::intersectFloor(observe(T, {13.0, -1.0, 0.0}, {13.0, 1.0, 0.0}), T, 570.0, options, &c));
  EXPECT_FALSE(ic::intersectFloor(observe(T, {5.0, -1.0, 1.5}, {5.0, 1.0, 1.5}), T, 570.0, options, &c));
}

TEST(FloorLines, DepthThatDisagreesWithTheFloorRefusesTheSegment)
{
  const ic::RgbdCamera camera = ic::test::xtionRgbdCamera();
  const Eigen::Isometry3d T = cameraAt(0.0, 0.0, 0.0);
  // Samples along the image of a floor edge 4 m ahead, with the floor's depth and with depth 0.5 m nearer.
  const auto [on_floor, nearer] = ic::test::floorLineDepthSamples(T, 4.0, 0.5);
  ic::FloorLineOptions options;
  EXPECT_TRUE(ic::depthAgreesWithFloor(on_floor, camera, T, options));
  EXPECT_FALSE(ic::depthAgreesWithFloor(nearer, camera, T, options));
  EXPECT_TRUE(ic::depthAgreesWithFloor({}, camera, T, options));  // no depth: nothing to disagree
}

namespace
{
// The share (by length) of the true floor edges in a camera's view that a map line holds: sample points along each
// edge projected into the image; a point counts as held when a map line parallel to the edge passes within
// max(1 cm, 3 sigma) of it.
double floorCoverage(const ic::CameraModel& camera, int width, int height, const std::vector<sim::TrueEdge>& edges,
                     const std::vector<ic::MapLine>& lines, const std::vector<double>& sigmas)
{
  size_t seen = 0, held = 0;
  for (const auto& e : edges)
  {
    if (!onFloor(e))
      continue;
    const Eigen::Vector3d d = (e.end - e.start).normalized();
    const int n = static_cast<int>((e.end - e.start).norm() / 0.05);
    for (int i = 0; i <= n; ++i)
    {
      const Eigen::Vector3d p = e.start + (e.end - e.start) * (static_cast<double>(i) / std::max(1, n));
      const auto px = camera.project(p);
      if (!px || px->x() < 0 || px->y() < 0 || px->x() >= width || px->y() >= height)
        continue;
      ++seen;
      for (size_t k = 0; k < lines.size(); ++k)
      {
        const auto& l = lines[k];
        const double s = (p - l.point).dot(l.direction);
        if (std::abs(l.direction.dot(d)) > std::cos(3.0 * M_PI / 180.0) && s >= l.s_min && s <= l.s_max &&
            distanceToLine(p, l.a(), l.b()) <= std::max(0.01, 3.0 * sigmas[k]))
        {
          ++held;
          break;
        }
      }
    }
  }
  return seen > 0 ? static_cast<double>(held) / seen : 0.0;
}

// The floor map lines counted by how far beyond the keyframes they reach and by their nearest parallel true edge.
struct FloorLineCounts
{
  int floor_lines = 0, beyond = 0, within = 0, off_floor = 0;
};

void countFloorLine(const ic::MapLine& line, double sigma, const std::vector<ic::Keyframe>& keyframes,
                    const std::vector<sim::TrueEdge>& edges, FloorLineCounts& count)
{
  ++count.floor_lines;
  // How far it reaches: its farther end's distance from the nearest keyframe (the Xtion's depth: 5 m).
  double reach = 0.0;
  for (const Eigen::Vector3d& end : {line.a(), line.b()})
  {
    double nearest = 1e9;
    for (const auto& kf : keyframes)
      nearest = std::min(nearest, (end - kf.T_map_camera.translation()).head<2>().norm());
    reach = std::max(reach, nearest);
  }
  count.beyond += reach > 5.0 ? 1 : 0;
  // The nearest true edge (any kind) parallel to it: must be a floor edge, within 3 predicted sigmas.
  double best = 1e9;
  bool on_floor = false;
  for (const auto& e : edges)
  {
    if (std::abs((e.end - e.start).normalized().dot(line.direction)) < std::cos(3.0 * M_PI / 180.0))
      continue;
    const double d = std::max(distanceToLine(line.a(), e.start, e.end), distanceToLine(line.b(), e.start, e.end));
    if (d < best)
    {
      best = d;
      on_floor = onFloor(e);
    }
  }
  count.off_floor += on_floor ? 0 : 1;
  if (getenv("FLOOR_VERBOSE"))
    std::printf("  floor line %.2f m long, reaching %.1f m, support %d, sigma %.1f mm, error %.1f mm, %s\n",
                line.length(), reach, line.support, 1000 * sigma, 1000 * best, on_floor ? "floor" : "OFF");
  count.within += on_floor && best <= 3.0 * sigma ? 1 : 0;
}
}  // namespace

TEST(FloorLines, SimulatedFloorHallGainsFloorLinesBeyondTheDepthRange)
{
  ic::SurveyOptions options;
  options.localization_sigma_m = 0.0;  // a perfect localiser: the floor lines alone
  options.localization_sigma_deg = 0.0;
  options.floor.enabled = true;
  ic::Survey survey({}, options);
  const auto world = ic::test::surveyWorldFile(kSource + "/config/worlds/floor_hall.yaml", 4, 40.0, &survey);
  ASSERT_TRUE(world) << world.error().describe();
  const auto edges = sim::computeTrueEdges(*world);

  const auto used = survey.usedMapLines();
  const auto sigmas = survey.mapLineSigmas();
  ASSERT_EQ(used.size(), sigmas.size());
  std::vector<ic::MapLine> depth_lines;
  std::vector<double> depth_sigmas;
  FloorLineCounts count;
  for (size_t i = 0; i < used.size(); ++i)
  {
    if (used[i].source == ic::MapLineSource::kDepth)
    {
      depth_lines.push_back(used[i]);
      depth_sigmas.push_back(sigmas[i]);
    }
    else
      countFloorLine(used[i], sigmas[i], survey.keyframes(), edges, count);
  }
  std::printf(
      "floor lines: %d used (%d reaching beyond 5 m of every keyframe), %d within 3 sigma of a true floor edge, %d "
      "nearest an edge off the floor; %zu candidates, %zu refused by depth\n",
      count.floor_lines, count.beyond, count.within, count.off_floor, survey.stats().floor_candidates,
      survey.stats().floor_refused);
  EXPECT_GE(count.beyond, 20);  // seed 4: 43 of 58
  EXPECT_EQ(count.off_floor, 0);
  EXPECT_GE(count.within, 0.95 * count.floor_lines);

  // Coverage of each fixed camera's true floor edges: depth lines only vs with the floor lines (seed 4: +30, +23
  // and +6 percentage points; cam_north looks at floor the 40 s route sees little of).
  double best_gain = 0.0;
  for (const auto& camera : world->fixed_cameras)
  {
    const double before = floorCoverage(camera.camera, camera.width, camera.height, edges, depth_lines, depth_sigmas);
    const double after = floorCoverage(camera.camera, camera.width, camera.height, edges, used, sigmas);
    std::printf("%s: floor-edge coverage %.1f %% with depth lines only, %.1f %% with the floor lines\n",
                camera.name.c_str(), 100.0 * before, 100.0 * after);
    EXPECT_GT(after, before + 0.05) << camera.name;
    best_gain = std::max(best_gain, after - before);
  }
  EXPECT_GT(best_gain, 0.2);
}
