// World files of the survey simulator: the shipped worlds meet the issue's specification, bad files are refused
// with a message naming the problem, and the route, textures and polygons behave as documented.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/trajectory.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "insitu_calibration/simulation/world.h"

namespace sim = insitu_calibration::simulation;
namespace ic = insitu_calibration;

namespace
{
const std::string kWorldDir = std::string(INSITU_SOURCE_DIR) + "/config/worlds/";

// A small valid world; tests break one thing in it at a time.
const char* kMinimalWorld = R"(
name: minimal
surfaces:
  - name: floor
    polygon: [[0, 0, 0], [4, 0, 0], [4, 3, 0], [0, 3, 0]]
  - name: wall
    wall: {from: [0, 3], to: [4, 3], height: 2.5}
route:
  waypoints: [[1, 1], [3, 1]]
fixed_cameras:
  - name: cam
    width: 640
    height: 480
    fx: 500
    position: [0.2, 0.2, 2.5]
    look_at: [2, 2, 0]
)";

std::string replaced(const std::string& text, const std::string& from, const std::string& to)
{
  std::string s = text;
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos)
    s.replace(at, from.size(), to);
  return s;
}

double cornerDisplacementPx(const sim::SimulatedFixedCamera& c)
{
  double d = 0.0;
  for (double x : {0.0, c.width - 1.0})
    for (double y : {0.0, c.height - 1.0})
    {
      const Eigen::Vector2d p(x, y);
      d = std::max(d, (*c.camera.distortion().undistort(p) - p).norm());
    }
  return d;
}

double lookingDownDeg(const sim::SimulatedFixedCamera& c)
{
  const Eigen::Vector3d forward = c.camera.pose().worldFromCamera().linear().col(2);
  return std::asin(-forward.z()) * 180.0 / M_PI;
}
}  // namespace

TEST(WorldFile, MinimalWorldParses)
{
  const auto world = sim::parseWorld(kMinimalWorld, "minimal.yaml");
  ASSERT_TRUE(world) << world.error().describe();
  EXPECT_EQ(world->name, "minimal");
  ASSERT_EQ(world->surfaces.size(), 2u);
  EXPECT_NEAR(world->surfaces[0].normal.z(), 1.0, 1e-12);
  ASSERT_EQ(world->fixed_cameras.size(), 1u);
  const sim::SimulatedFixedCamera& c = world->fixed_cameras[0];
  EXPECT_DOUBLE_EQ(c.camera.intrinsics().fy, 500.0);  // fy defaults to fx
  EXPECT_DOUBLE_EQ(c.camera.intrinsics().cx, 319.5);  // principal point defaults to the centre
  EXPECT_LT((c.camera.pose().center() - Eigen::Vector3d(0.2, 0.2, 2.5)).norm(), 1e-12);
  // look_at: the optical axis points at the target.
  const auto target = c.camera.projectUndistorted(Eigen::Vector3d(2, 2, 0));
  ASSERT_TRUE(target);
  EXPECT_LT((*target - Eigen::Vector2d(319.5, 239.5)).norm(), 1e-9);
}

namespace
{
struct BadWorldCase
{
  std::string name;
  std::string text;
  ic::ErrorCode code;
  std::vector<std::string> words;  // all must appear in the message
};

// The minimal world with one mistake each, the error code due and words its message must hold.
std::vector<BadWorldCase> badWorldCases()
{
  const std::string w = kMinimalWorld;
  return {
      {"missing focal length",
       replaced(w, "    fx: 500\n", ""),
       ic::ErrorCode::kParseError,
       {"fixed_cameras[0]", "'cam'", "missing key 'fx'"}},
      {"missing route",
       replaced(w, "route:\n  waypoints: [[1, 1], [3, 1]]\n", ""),
       ic::ErrorCode::kParseError,
       {"missing key 'route'"}},
      {"surface without a shape",
       replaced(w, "    polygon: [[0, 0, 0], [4, 0, 0], [4, 3, 0], [0, 3, 0]]\n", ""),
       ic::ErrorCode::kParseError,
       {"surfaces[0]", "'floor'", "missing key", "polygon"}},
      {"polygon with 2 vertices",
       replaced(w, "[[0, 0, 0], [4, 0, 0], [4, 3, 0], [0, 3, 0]]", "[[0, 0, 0], [4, 0, 0]]"),
       ic::ErrorCode::kInvalidInput,
       {"surfaces[0]", "'floor'", "2 vertices", "at least 3"}},
      {"zero focal length",
       replaced(w, "fx: 500", "fx: 0"),
       ic::ErrorCode::kInvalidInput,
       {"fixed_cameras[0]", "'cam'", "fx", "must be positive", "got 0"}},
      {"negative focal length",
       replaced(w, "fx: 500", "fx: 500\n    fy: -3"),
       ic::ErrorCode::kInvalidInput,
       {"fy", "must be positive", "got -3"}},
      {"non-planar polygon",
       replaced(w, "[4, 3, 0], [0, 3, 0]]", "[4, 3, 0.2], [0, 3, 0]]"),
       ic::ErrorCode::kInvalidInput,
       {"'floor'", "not planar", "mm off the plane"}},
      {"collinear polygon",
       replaced(w, "[[0, 0, 0], [4, 0, 0], [4, 3, 0], [0, 3, 0]]", "[[0, 0, 0], [1, 0, 0], [2, 0, 0]]"),
       ic::ErrorCode::kInvalidInput,
       {"'floor'", "zero area"}},
      {"unknown key",
       replaced(w, "fx: 500", "fx: 500\n    focal: 3"),
       ic::ErrorCode::kParseError,
       {"unknown key 'focal'"}},
      {"not a number",
       replaced(w, "fx: 500", "fx: five"),
       ic::ErrorCode::kParseError,
       {"fx", "'five' is not a number"}},
      {"one waypoint",
       replaced(w, "[[1, 1], [3, 1]]", "[[1, 1]]"),
       ic::ErrorCode::kInvalidInput,
       {"route.waypoints", "at least 2"}},
      {"bad camera name", replaced(w, "name: cam", "name: my cam"), ic::ErrorCode::kInvalidInput, {"ROS name"}},
      {"no camera orientation",
       replaced(w, "    look_at: [2, 2, 0]\n", ""),
       ic::ErrorCode::kParseError,
       {"look_at", "orientation"}},
      {"distortion without rays",
       replaced(w, "fx: 500", "fx: 500\n    lambda: -1e-5"),
       ic::ErrorCode::kInvalidInput,
       {"lambda", "too strong"}},
      {"bad colour",
       replaced(w, "    wall: {", "    texture: {color: [300, 0, 0]}\n    wall: {"),
       ic::ErrorCode::kInvalidInput,
       {"texture.color", "0..255"}},
      {"not YAML", "surfaces: [", ic::ErrorCode::kParseError, {"not valid YAML"}},
  };
}
}  // namespace

TEST(WorldFile, BadFilesAreRefusedWithTheProblemNamed)
{
  for (const BadWorldCase& c : badWorldCases())
  {
    const auto world = sim::parseWorld(c.text, "bad.yaml");
    ASSERT_FALSE(world) << c.name;
    EXPECT_EQ(world.error().code(), c.code) << c.name << ": " << world.error().describe();
    for (const auto& word : c.words)
      EXPECT_NE(world.error().message().find(word), std::string::npos)
          << c.name << ": '" << word << "' not in: " << world.error().message();
    EXPECT_EQ(world.error().message().rfind("bad.yaml", 0), 0u) << c.name << ": " << world.error().message();
  }
  const auto missing = sim::loadWorldFile("/nonexistent/world.yaml");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code(), ic::ErrorCode::kIoError);
}

TEST(WorldFile, ShapesBecomePolygons)
{
  const std::string text = replaced(kMinimalWorld, "  - name: wall\n", R"(  - name: box
    box: {min: [1, 1, 0], max: [2, 1.5, 0.8], yaw_deg: 30}
  - name: poster
    rectangle: {center: [2, 2.99, 1.5], normal: [0, -1, 0], size: [0.6, 0.8]}
  - name: wall
)");
  const auto text2 = replaced(text, "wall: {from: [0, 3], to: [4, 3], height: 2.5}",
                              "wall: {from: [0, 3], to: [4, 3], height: 2.5, openings: [{offset: 1, width: 1, "
                              "height: 2}, {offset: 2.5, width: 1, height: 1, sill: 1}]}");
  const auto world = sim::parseWorld(text2, "shapes.yaml");
  ASSERT_TRUE(world) << world.error().describe();
  // floor, 5 box faces (no bottom), poster, wall.
  ASSERT_EQ(world->surfaces.size(), 8u);
  EXPECT_EQ(world->surfaces[1].name, "box/-y");
  EXPECT_EQ(world->surfaces[5].name, "box/top");
  // Box faces point outwards.
  const Eigen::Vector3d box_center(1.5, 1.25, 0.4);
  for (int i = 1; i <= 5; ++i)
  {
    const sim::Surface& s = world->surfaces[i];
    EXPECT_GT(s.normal.dot(s.rings[0][0] - box_center), 0.0) << s.name;
  }
  // The rectangle's texture frame: u to the right, v up, seen from the front (the normal's side).
  const sim::Surface& poster = world->surfaces[6];
  EXPECT_LT((poster.axis_v - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_LT((poster.axis_u - Eigen::Vector3d(1, 0, 0)).norm(), 1e-12);  // facing north, east is right
  EXPECT_LT((poster.toWorld({0, 0}) - Eigen::Vector3d(1.7, 2.99, 1.1)).norm(), 1e-12);
  // The wall: a doorway notch and a window hole.
  const sim::Surface& wall = world->surfaces[7];
  ASSERT_EQ(wall.rings.size(), 2u);
  EXPECT_TRUE(wall.contains({0.5, 1.0}));
  EXPECT_FALSE(wall.contains({1.5, 1.0}));                           // doorway
  EXPECT_TRUE(wall.contains({1.5, 2.2}));                            // above the doorway
  EXPECT_FALSE(wall.contains({3.0, 1.5}));                           // window
  EXPECT_TRUE(wall.contains({3.0, 0.5}));                            // below the window
  EXPECT_NEAR(wall.distance(wall.toWorld({3.0, 1.5})), 0.5, 1e-12);  // to the window's edges
  EXPECT_NEAR(wall.distance(wall.toWorld({0.5, 1.0}) + 0.3 * wall.normal), 0.3, 1e-12);
}

TEST(WorldFile, TexturesHaveRegionsAtTheirEdges)
{
  sim::Texture t;
  t.pattern = sim::Texture::Pattern::kChecker;
  t.cell = Eigen::Vector2d(0.5, 0.25);
  int r1 = 0, r2 = 0;
  EXPECT_EQ(t.sample(0.1, 0.1, &r1), t.color);
  EXPECT_EQ(t.sample(0.6, 0.1, &r2), t.color2);
  EXPECT_NE(r1, r2);
  EXPECT_EQ(t.sample(0.6, 0.3, &r2), t.color);
  t.rects.push_back({{0.0, 0.0}, {1.0, 1.0}, sim::Color(1, 2, 3)});
  t.rects.push_back({{0.5, 0.5}, {0.7, 0.7}, sim::Color(4, 5, 6)});
  EXPECT_EQ(t.sample(0.6, 0.6, &r1), sim::Color(4, 5, 6));  // the last rectangle is on top
  EXPECT_EQ(r1, 3);
  EXPECT_EQ(t.sample(0.2, 0.6, &r1), sim::Color(1, 2, 3));
  EXPECT_EQ(r1, 2);
}

TEST(Trajectory, FollowsTheRouteAndTheMounting)
{
  sim::Route route;
  route.waypoints = {{0, 0}, {2, 0}, {2, 1}};
  route.speed = 0.5;
  route.turn_rate_deg = 45.0;
  route.loop = true;
  const sim::RouteTrajectory t(route);
  // 4 s east, 2 s turning 90 deg, 2 s north, 3 s turning 135 deg, sqrt(5)/0.5 s back, 3 s turning 135 deg.
  EXPECT_NEAR(t.lapDuration(), 4 + 2 + 2 + 3 + std::sqrt(5.0) / 0.5 + 3, 1e-9);
  sim::Pose2d p = t.at(2.0);
  EXPECT_NEAR(p.x, 1.0, 1e-12);
  EXPECT_NEAR(p.yaw, 0.0, 1e-12);
  p = t.at(5.0);  // half-way through the first turn
  EXPECT_NEAR(p.x, 2.0, 1e-12);
  EXPECT_NEAR(p.yaw, M_PI / 4, 1e-12);
  p = t.at(7.0);
  EXPECT_NEAR(p.y, 0.5, 1e-12);
  EXPECT_NEAR(p.yaw, M_PI / 2, 1e-12);
  p = t.at(t.lapDuration() + 2.0);  // second lap
  EXPECT_NEAR(p.x, 1.0, 1e-9);
  EXPECT_NEAR(p.y, 0.0, 1e-9);
  route.loop = false;
  const sim::RouteTrajectory once(route);
  p = once.at(1000.0);
  EXPECT_NEAR(p.x, 2.0, 1e-12);
  EXPECT_NEAR(p.y, 1.0, 1e-12);

  sim::XtionConfig x;
  x.mount_height_m = 1.2;
  x.mount_forward_m = 0.1;
  x.tilt_deg = 10.0;
  const Eigen::Isometry3d optical = sim::baseFromRgbOptical(x);
  // The optical axis looks forward (+x of base_link) and 10 degrees up; the RGB camera is 4.5 cm to the right.
  const Eigen::Vector3d z = optical.linear().col(2);
  EXPECT_NEAR(std::asin(z.z()) * 180.0 / M_PI, 10.0, 1e-9);
  EXPECT_NEAR(z.y(), 0.0, 1e-12);
  EXPECT_GT(z.x(), 0.9);
  EXPECT_NEAR(optical.translation().z(), 1.2, 1e-12);
  EXPECT_NEAR(optical.translation().y(), -0.045, 1e-12);
  EXPECT_NEAR(optical.linear().col(0).y(), -1.0, 1e-12);  // optical x = right = -y of base_link
}

TEST(DefaultWorld, MeetsTheSpecification)
{
  const auto world = sim::loadWorldFile(kWorldDir + "waiting_room.yaml");
  ASSERT_TRUE(world) << world.error().describe();
  // About 8 x 6 x 3 m.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  for (const auto& s : world->surfaces)
    for (const auto& p : s.rings[0])
    {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  EXPECT_LT((hi - lo - Eigen::Vector3d(8, 6, 3)).cwiseAbs().maxCoeff(), 0.01);
  EXPECT_GE(world->surfaces.size(), 100u);
  ASSERT_GE(world->fixed_cameras.size(), 3u);
  bool noticeable = false, wide = false, small = false;
  for (const auto& c : world->fixed_cameras)
  {
    SCOPED_TRACE(c.name);
    EXPECT_GE(c.camera.pose().center().z(), 2.5);
    EXPECT_LE(c.camera.pose().center().z(), 3.0);
    EXPECT_GE(lookingDownDeg(c), 15.0);
    EXPECT_LE(lookingDownDeg(c), 40.0);
    const double corner = cornerDisplacementPx(c);
    noticeable |= c.width == 1280 && c.height == 960 && corner >= 10.0 && corner <= 20.0;
    wide |= c.width == 1920 && c.height == 1080 && corner >= 30.0;
    small |= c.width == 640 && c.height == 480;
  }
  EXPECT_TRUE(noticeable) << "a 1280x960 camera with corners displaced 10-20 px";
  EXPECT_TRUE(wide) << "a 1920x1080 camera with corners displaced 30+ px";
  EXPECT_TRUE(small) << "a 640x480 camera";
}

// The 640x480 camera sees partly a region the robot never drives through: a good share of its pixels shows surfaces
// farther than 1.5 m (horizontally) from any point of the route, and a good share nearer.
TEST(DefaultWorld, SmallCameraSeesARegionTheRobotNeverVisits)
{
  const auto world = sim::loadWorldFile(kWorldDir + "waiting_room.yaml");
  ASSERT_TRUE(world) << world.error().describe();
  const sim::RouteTrajectory route(world->route);
  const auto path = route.pathPoints(0.05);
  const sim::Renderer renderer(*world);
  for (const auto& c : world->fixed_cameras)
  {
    if (c.width != 640)
      continue;
    sim::RenderOptions options;
    options.color = false;
    const sim::ViewCamera cam = sim::ViewCamera::fromModel(c.camera, c.width, c.height);
    const sim::RenderedView view = renderer.render(cam, options);
    int far = 0, near = 0;
    for (int y = 0; y < c.height; y += 4)
      for (int x = 0; x < c.width; x += 4)
      {
        const float z = view.depth.at<float>(y, x);
        if (z <= 0.0f)
          continue;
        const Eigen::Vector3d p = cam.world_from_camera * (static_cast<double>(z) * *cam.ray(x, y));
        if (p.z() > 2.0)
          continue;  // ceiling and high walls: not a region one drives through
        double d = 1e9;
        for (const auto& q : path)
          d = std::min(d, (p.head<2>() - q).norm());
        (d > 1.5 ? far : near)++;
      }
    const double share = static_cast<double>(far) / (far + near);
    std::printf("%s: %.0f %% of the low surfaces it sees are more than 1.5 m from the route\n", c.name.c_str(),
                100.0 * share);
    EXPECT_GT(share, 0.25);
    EXPECT_LT(share, 0.9);
    return;
  }
  FAIL() << "no 640x480 camera";
}

TEST(CorridorWorld, LoadsAndIsLarger)
{
  const auto world = sim::loadWorldFile(kWorldDir + "corridor.yaml");
  ASSERT_TRUE(world) << world.error().describe();
  EXPECT_GE(world->fixed_cameras.size(), 5u);
  const sim::RouteTrajectory route(world->route);
  EXPECT_GT(route.lapDuration(), 120.0);
  const auto edges = sim::computeTrueEdges(*world);
  EXPECT_GT(edges.size(), 500u);
}

// The robot (a 0.3 m radius, 1.3 m tall cylinder) never drives through anything in the shipped worlds.
TEST(ShippedWorlds, RouteKeepsClearOfObstacles)
{
  for (const std::string name : {"waiting_room.yaml", "corridor.yaml"})
  {
    const auto world = sim::loadWorldFile(kWorldDir + name);
    ASSERT_TRUE(world) << world.error().describe();
    const sim::RouteTrajectory route(world->route);
    double closest = 1e9;
    std::string closest_surface;
    for (const auto& p : route.pathPoints(0.05))
      for (const auto& s : world->surfaces)
      {
        double lo = 1e9, hi = -1e9;
        for (const auto& v : s.rings[0])
        {
          lo = std::min(lo, v.z());
          hi = std::max(hi, v.z());
        }
        if (hi < 0.05 || lo > 1.3)
          continue;  // the floor, rugs, the ceiling and what hangs from it
        for (const double z : {0.05, 0.4, 0.8, 1.2})
        {
          const double d = s.distance(Eigen::Vector3d(p.x(), p.y(), z));
          if (d < closest)
          {
            closest = d;
            closest_surface = s.name;
          }
        }
      }
    std::printf("%s: the route passes %.2f m from %s at the closest\n", name.c_str(), closest, closest_surface.c_str());
    EXPECT_GE(closest, 0.3) << name << ": " << closest_surface;
  }
}
