// The procedural buildings of generate_world: they load, their cameras see the building, their routes cover the
// floor without touching anything, and the installer priors are off by exactly the requested amounts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>

#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/route_planner.h"
#include "insitu_calibration/simulation/trajectory.h"
#include "insitu_calibration/simulation/world_generator.h"
#include "insitu_calibration/survey/camera_config.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
constexpr double kRadToDeg = 180.0 / M_PI;

struct Case
{
  uint64_t seed;
  sim::BuildingKind kind;
};
const Case kCases[] = {{1, sim::BuildingKind::kRoom},     {2, sim::BuildingKind::kHall},
                       {3, sim::BuildingKind::kCorridor}, {4, sim::BuildingKind::kOffice},
                       {5, sim::BuildingKind::kRoom},     {6, sim::BuildingKind::kHall},
                       {7, sim::BuildingKind::kCorridor}, {8, sim::BuildingKind::kOffice}};

sim::GeneratedWorld generate(const Case& c, double max_route_s = 0.0)
{
  sim::WorldGeneratorOptions options;
  options.seed = c.seed;
  options.kind = c.kind;
  options.max_route_s = max_route_s;
  auto world = sim::generateWorld(options);
  EXPECT_TRUE(world) << (world ? "" : world.error().describe());
  return world ? *world : sim::GeneratedWorld{};
}

// The surfaces a 1.3 m tall robot could touch (not the floor, rugs, the ceiling or what hangs from it).
bool standsOnFloor(const sim::Surface& s)
{
  double lo = 1e9, hi = -1e9;
  for (const auto& v : s.rings[0])
  {
    lo = std::min(lo, v.z());
    hi = std::max(hi, v.z());
  }
  return hi >= 0.05 && lo <= 1.3;
}
}  // namespace

TEST(WorldGenerator, SameSeedSameFilesOtherSeedOtherBuilding)
{
  const auto a = generate(kCases[0]), b = generate(kCases[0]), c = generate(kCases[4]);
  EXPECT_EQ(a.world_yaml, b.world_yaml);
  EXPECT_EQ(a.cameras_yaml, b.cameras_yaml);
  EXPECT_NE(a.world_yaml, c.world_yaml);
  sim::WorldGeneratorOptions drawn;
  drawn.seed = 12345;
  EXPECT_TRUE(sim::generateWorld(drawn));
  EXPECT_FALSE(sim::parseBuildingKind("castle"));
}

// Cameras within the ranges, each seeing only building (no void through an opening or past a wall) and
// several surfaces of it.
TEST(WorldGenerator, CamerasAreInstalledAsSpecifiedAndSeeTheBuilding)
{
  for (const Case& c : kCases)
  {
    const auto g = generate(c);
    ASSERT_GE(g.world.fixed_cameras.size(), 2u) << g.world.name;
    const sim::Renderer renderer(g.world);
    for (const auto& cam : g.world.fixed_cameras)
    {
      const auto& k = cam.camera.intrinsics();
      const double fov = 2.0 * std::atan(0.5 * cam.width / k.fx) * kRadToDeg;
      const Eigen::Vector3d p = cam.camera.pose().center();
      EXPECT_GE(p.z(), 2.4) << cam.name;
      EXPECT_LE(p.z(), 5.0) << cam.name;
      EXPECT_GE(fov, 30.0) << cam.name;
      EXPECT_LE(fov, 110.0) << cam.name;
      EXPECT_LE(std::abs(k.cx - 0.5 * (cam.width - 1)), 0.03 * cam.width + 1e-6);
      EXPECT_LE(std::abs(k.cy - 0.5 * (cam.height - 1)), 0.03 * cam.height + 1e-6);
      EXPECT_GE(cam.width, 640);
      EXPECT_LE(cam.width, 2560);
      const auto corner = cam.camera.distortion().undistort(Eigen::Vector2d(0, 0));
      ASSERT_TRUE(corner);
      EXPECT_LE((*corner - Eigen::Vector2d(0, 0)).norm(), 61.0) << cam.name;
      // Rendered at a quarter of the size (the same view): every pixel on a surface, many surfaces.
      const double s = 0.25;
      ic::Intrinsics small{k.fx * s, k.fy * s, 0.0, (k.cx + 0.5) * s - 0.5, (k.cy + 0.5) * s - 0.5};
      ic::DivisionModel d = cam.camera.distortion();
      d.lambda /= s * s;
      d.center = (d.center + Eigen::Vector2d(0.5, 0.5)) * s - Eigen::Vector2d(0.5, 0.5);
      const auto view = sim::ViewCamera::fromModel(ic::CameraModel(small, d, cam.camera.pose()),
                                                   static_cast<int>(cam.width * s), static_cast<int>(cam.height * s));
      sim::RenderOptions options;
      options.color = false;
      options.supersampling = 1;
      const auto rendered = renderer.render(view, options);
      std::set<int> seen;
      int void_pixels = 0;
      for (int y = 0; y < rendered.surface.rows; ++y)
        for (int x = 0; x < rendered.surface.cols; ++x)
        {
          const int id = rendered.surface.at<int>(y, x);
          void_pixels += id < 0 ? 1 : 0;
          seen.insert(id);
        }
      EXPECT_EQ(void_pixels, 0) << g.world.name << " " << cam.name;
      EXPECT_GE(seen.size(), 4u) << g.world.name << " " << cam.name;
    }
  }
}

// The robot (0.3 m radius, 1.3 m tall) never drives through anything, and passes within 1.5 m of most of the floor.
TEST(WorldGenerator, RouteCoversTheFloorAndKeepsClear)
{
  for (const Case& c : kCases)
  {
    const auto g = generate(c);
    const sim::RouteTrajectory route(g.world.route);
    const auto path = route.pathPoints(0.05);
    double closest = 1e9;
    std::string closest_surface;
    for (const auto& p : path)
      for (const auto& s : g.world.surfaces)
        if (standsOnFloor(s))
          for (const double z : {0.05, 0.4, 0.8, 1.2})
          {
            const double d = s.distance(Eigen::Vector3d(p.x(), p.y(), z));
            if (d < closest)
            {
              closest = d;
              closest_surface = s.name;
            }
          }
    EXPECT_GE(closest, 0.3) << g.world.name << ": " << closest_surface;
    // Floor coverage: points of the floor within 1.05 m of the path's extent (the walls are 0.45 m beyond it), 0.6 m
    // clear of anything standing, within 1.5 m of the path.
    Eigen::AlignedBox2d box;
    for (const auto& p : path)
      box.extend(p);
    int near = 0, total = 0;
    const auto& floor = g.world.surfaces.front();
    for (double x = box.min().x() - 1.05; x <= box.max().x() + 1.05; x += 0.25)
      for (double y = box.min().y() - 1.05; y <= box.max().y() + 1.05; y += 0.25)
      {
        const Eigen::Vector3d q(x, y, 0.4);
        if (floor.distance(Eigen::Vector3d(x, y, 0.0)) > 1e-6)
          continue;
        bool clear = true;
        for (const auto& s : g.world.surfaces)
          clear = clear && (!standsOnFloor(s) || s.distance(q) > 0.6);
        if (!clear)
          continue;
        double d = 1e9;
        for (const auto& p : path)
          d = std::min(d, (p - q.head<2>()).norm());
        ++total;
        near += d <= 1.5 ? 1 : 0;
      }
    std::printf("%s: route %.0f s, %zu waypoints, clearance %.2f m, %d of %d free floor points within 1.5 m\n",
                g.world.name.c_str(), g.route_duration_s, g.world.route.waypoints.size(), closest, near, total);
    EXPECT_GE(near, 0.85 * total) << g.world.name;
  }
}

TEST(WorldGenerator, RouteBudgetIsKept)
{
  for (const Case& c : kCases)
  {
    const auto g = generate(c, 40.0);
    EXPECT_LE(g.route_duration_s, 40.0 + 1e-6) << g.world.name;
    EXPECT_GE(g.route_duration_s, 10.0) << g.world.name;
  }
}

// The priors in config/cameras.yaml's format, each exactly 0.5 m, 10 deg and 20 % (or as asked) from the truth.
TEST(WorldGenerator, PriorsAreOffByTheRequestedAmounts)
{
  for (const double scale : {1.0, 0.5})
  {
    sim::WorldGeneratorOptions options;
    options.seed = 9;
    options.prior_error = {0.5 * scale, 10.0 * scale, 0.2 * scale};
    const auto g = sim::generateWorld(options);
    ASSERT_TRUE(g);
    const auto priors = ic::parseCameraConfig(g->cameras_yaml);
    ASSERT_TRUE(priors) << priors.error().describe();
    ASSERT_EQ(priors->size(), g->world.fixed_cameras.size());
    for (size_t k = 0; k < priors->size(); ++k)
    {
      const auto& truth = g->world.fixed_cameras[k];
      const ic::CameraPrior& p = *(*priors)[k].camera.prior;
      EXPECT_EQ((*priors)[k].camera.name, truth.name);
      EXPECT_EQ((*priors)[k].camera.image_width, truth.width);
      EXPECT_NEAR((p.position - truth.camera.pose().center()).norm(), 0.5 * scale, 2e-3);
      const Eigen::Vector3d axis = truth.camera.pose().rotation.row(2).transpose();
      EXPECT_NEAR(std::acos(std::clamp(p.direction.normalized().dot(axis), -1.0, 1.0)) * kRadToDeg, 10.0 * scale, 0.3);
      const double fov = 2.0 * std::atan(0.5 * truth.width / truth.camera.intrinsics().fx) * kRadToDeg;
      EXPECT_NEAR(std::abs(p.horizontal_fov_deg / fov - 1.0), 0.2 * scale, 2e-3);
      EXPECT_DOUBLE_EQ(p.position_sigma_m, 0.5 * scale);
    }
  }
}

TEST(RoutePlanner, LanesAcrossAnEmptyRoomAndAroundAnObstacle)
{
  sim::FloorPlan plan;
  plan.walkable = Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 6));
  const auto empty = sim::planCoverageRoute(plan, {});
  ASSERT_TRUE(empty);
  EXPECT_EQ(empty->size(), 8u);  // four lanes 1.5 m apart, each two waypoints
  plan.obstacles.push_back(
      {Eigen::Vector2d(4, 0), Eigen::Vector2d(6, 0), Eigen::Vector2d(6, 4), Eigen::Vector2d(4, 4)});
  const auto around = sim::planCoverageRoute(plan, {});
  ASSERT_TRUE(around);
  for (size_t k = 1; k < around->size(); ++k)
    for (double t = 0; t <= 1.0; t += 0.01)
    {
      const Eigen::Vector2d p = (*around)[k - 1] + t * ((*around)[k] - (*around)[k - 1]);
      EXPECT_GT(sim::distanceToFootprint(p, plan.obstacles[0]), 0.4);
    }
  plan.walkable = Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(0.8, 6));
  EXPECT_FALSE(sim::planCoverageRoute(plan, {}));
}

namespace
{
// A 10 x 6 m room with one rectangular block standing on its floor.
sim::FloorPlan roomWithBlock(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi)
{
  sim::FloorPlan plan;
  plan.walkable = Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 6));
  plan.obstacles.push_back({lo, Eigen::Vector2d(hi.x(), lo.y()), hi, Eigen::Vector2d(lo.x(), hi.y())});
  return plan;
}

// The 10-degree heading bins the robot faces (driving or turning in place) while within `radius` of `place`.
std::set<int> headingsNear(const sim::RouteTrajectory& trajectory, const Eigen::Vector2d& place, double radius)
{
  std::set<int> bins;
  for (double t = 0.0; t <= trajectory.lapDuration(); t += 0.02)
  {
    const sim::Pose2d pose = trajectory.at(t);
    if ((Eigen::Vector2d(pose.x, pose.y) - place).norm() <= radius)
      bins.insert(static_cast<int>(std::floor(std::remainder(pose.yaw, 2.0 * M_PI) * kRadToDeg + 180.0)) / 10 % 36);
  }
  return bins;
}
}  // namespace

// Lanes alone never face the wall their connectors turn away from; look-arounds face every direction at places
// spread over the room, and keep the clearance.
TEST(RoutePlanner, LookAroundsFaceEveryDirectionAndKeepClear)
{
  const sim::FloorPlan plan = roomWithBlock(Eigen::Vector2d(4, 2), Eigen::Vector2d(6, 3));
  sim::RoutePlanOptions options;
  const auto lanes = sim::planCoverageRoute(plan, options);
  options.look_around_spacing_m = 3.0;
  const auto looking = sim::planCoverageRoute(plan, options);
  ASSERT_TRUE(lanes && looking);
  const auto trajectoryOf = [](const std::vector<Eigen::Vector2d>& waypoints) {
    sim::Route route;
    route.waypoints = waypoints;
    route.loop = false;
    return sim::RouteTrajectory(route);
  };
  // Facing -y (the wall the connectors turn their back on): the bins of -100..-80 deg.
  const auto facesMinusY = [](const std::set<int>& bins) { return bins.count(8) + bins.count(9) > 0; };
  EXPECT_FALSE(facesMinusY(headingsNear(trajectoryOf(*lanes), Eigen::Vector2d(5, 3), 20.0)));
  const sim::RouteTrajectory trajectory = trajectoryOf(*looking);
  // Every full turn of the look-arounds, found where the robot faces all 36 bins within 0.5 m.
  std::vector<Eigen::Vector2d> places;
  for (const Eigen::Vector2d& w : *looking)
  {
    bool known = false;
    for (const auto& p : places)
      known = known || (p - w).norm() < 1.0;
    if (!known && headingsNear(trajectory, w, 0.5).size() == 36)
      places.push_back(w);
  }
  std::printf("%zu waypoints, %zu look-arounds facing every direction, lap %.0f s (lanes only: %.0f s)\n",
              looking->size(), places.size(), trajectory.lapDuration(), trajectoryOf(*lanes).lapDuration());
  EXPECT_TRUE(facesMinusY(headingsNear(trajectory, Eigen::Vector2d(5, 3), 20.0)));
  EXPECT_GE(places.size(), 8u);  // 4 lanes of about 9 m, a look-around every 3 m where the square is free
  double spread_x = 0.0, spread_y = 0.0;
  for (const auto& p : places)
  {
    spread_x = std::max(spread_x, std::abs(p.x() - places.front().x()));
    spread_y = std::max(spread_y, std::abs(p.y() - places.front().y()));
  }
  EXPECT_GT(spread_x, 5.0);
  EXPECT_GT(spread_y, 3.0);
  for (size_t k = 1; k < looking->size(); ++k)
    for (double t = 0; t <= 1.0; t += 0.01)
    {
      const Eigen::Vector2d p = (*looking)[k - 1] + t * ((*looking)[k] - (*looking)[k - 1]);
      EXPECT_GT(sim::distanceToFootprint(p, plan.obstacles[0]), 0.4);
      EXPECT_TRUE(plan.walkable.contains(p));
    }
}

// View legs come first: from the free cell nearest their start along their direction, as far as the floor is free
// (here: up to the obstacle), then the lanes; a leg that starts far outside the floor is left out.
TEST(RoutePlanner, ViewLegsAreDrivenFirstAlongTheirDirections)
{
  const sim::FloorPlan plan = roomWithBlock(Eigen::Vector2d(6, 2), Eigen::Vector2d(7, 4));
  sim::RoutePlanOptions options;
  // A camera on the west wall looking east (its leg stops 0.45 m before the obstacle at x = 6), one in the north-east
  // corner looking south-west, and one 8 m outside the building.
  options.view_legs = {{Eigen::Vector2d(0.2, 3.0), Eigen::Vector2d(1, 0), 8.0},
                       {Eigen::Vector2d(9.8, 5.8), Eigen::Vector2d(-1, -1), 3.0},
                       {Eigen::Vector2d(-8.0, 3.0), Eigen::Vector2d(1, 0), 4.0}};
  const auto route = sim::planCoverageRoute(plan, options);
  ASSERT_TRUE(route);
  ASSERT_GE(route->size(), 6u);
  const auto& w = *route;
  EXPECT_NEAR(w[0].x(), 0.45, 0.11);
  EXPECT_NEAR(w[0].y(), 3.0, 0.11);
  EXPECT_NEAR(w[1].y(), w[0].y(), 1e-9);
  EXPECT_NEAR(w[1].x(), 6.0 - 0.45, 0.15);
  // The second leg (after a way around the obstacle): from the free cell nearest the corner camera, 3 m towards the
  // south-west.
  const auto corner = std::find_if(w.begin() + 2, w.end(), [](const Eigen::Vector2d& p) {
    return (p - Eigen::Vector2d(10.0 - 0.45, 6.0 - 0.45)).norm() < 0.11;
  });
  ASSERT_TRUE(corner != w.end() && corner + 1 != w.end());
  const Eigen::Vector2d second = *(corner + 1) - *corner;
  EXPECT_NEAR(second.norm(), 3.0, 0.15);
  EXPECT_GT(second.normalized().dot(Eigen::Vector2d(-1, -1).normalized()), std::cos(3.0 * M_PI / 180.0));
  // Then the lanes (the plan without view legs) from its first waypoint on; nothing of the far camera's leg.
  options.view_legs.clear();
  const auto lanes = sim::planCoverageRoute(plan, options);
  ASSERT_TRUE(lanes);
  const auto start =
      std::find_if(corner + 2, w.end(), [&](const Eigen::Vector2d& p) { return (p - lanes->front()).norm() < 1e-9; });
  ASSERT_NE(start, w.end());
  EXPECT_EQ(static_cast<size_t>(w.end() - start), lanes->size());
  for (const auto& p : w)
    EXPECT_GT(p.x(), 0.4);
}

// Visits after the route (a refused camera's survey hints): the robot reaches each standpoint (the free cell nearest
// it), never comes within the clearance of the obstacle or the walls, and ends each visit facing its look direction;
// a standpoint far outside the floor is left out and counted.
TEST(RoutePlanner, VisitsReachEachStandpointAndEndFacingItsDirection)
{
  const sim::FloorPlan plan = roomWithBlock(Eigen::Vector2d(4, 2), Eigen::Vector2d(6, 3));
  const auto lanes = sim::planCoverageRoute(plan, {});
  ASSERT_TRUE(lanes);
  // Behind the block looking at it from the north (the sweep ahead is free), in the south-west corner looking into
  // the corner (the floor ahead is blocked: the sweep ends at the standpoint), and 20 m outside.
  const std::vector<sim::Visit> visits = {{Eigen::Vector2d(5.0, 4.5), Eigen::Vector2d(0, -1)},
                                          {Eigen::Vector2d(0.6, 0.6), Eigen::Vector2d(-1, -1).normalized()},
                                          {Eigen::Vector2d(30.0, 3.0), Eigen::Vector2d(1, 0)}};
  size_t skipped = 0;
  const auto route = sim::appendVisits(plan, *lanes, visits, {}, &skipped);
  ASSERT_TRUE(route) << route.error().describe();
  EXPECT_EQ(skipped, 1u);
  ASSERT_GT(route->size(), lanes->size());
  for (size_t k = 0; k < lanes->size(); ++k)
    EXPECT_EQ((*route)[k], (*lanes)[k]);  // the route before the visits is kept
  for (size_t k = 1; k < route->size(); ++k)
    for (double t = 0; t <= 1.0; t += 0.01)
    {
      const Eigen::Vector2d p = (*route)[k - 1] + t * ((*route)[k] - (*route)[k - 1]);
      EXPECT_GT(sim::distanceToFootprint(p, plan.obstacles[0]), 0.44);
      EXPECT_TRUE(plan.walkable.contains(p));
      EXPECT_GT(std::min({p.x(), p.y(), 10.0 - p.x(), 6.0 - p.y()}), 0.44) << p.transpose();
    }
  sim::Route r;
  r.waypoints = *route;
  r.loop = false;
  const sim::RouteTrajectory trajectory(r);
  r.waypoints = *lanes;
  const double lanes_s = sim::RouteTrajectory(r).lapDuration();  // the visits are driven after this
  // The robot ends the route facing the last visit's direction, at the end of its sweep or at its standpoint.
  const sim::Pose2d end = trajectory.at(trajectory.lapDuration() + 1.0);
  const auto facing = [](const sim::Pose2d& pose, const Eigen::Vector2d& d) {
    return Eigen::Vector2d(std::cos(pose.yaw), std::sin(pose.yaw)).dot(d.normalized());
  };
  // Each visit: some moment near its standpoint (within the sweep's reach) facing its direction within 1 deg, just
  // before the robot turns away.
  for (size_t v = 0; v < 2; ++v)
  {
    const Eigen::Vector2d stand = visits[v].standpoint;
    bool reached = false;
    for (double t = lanes_s; t <= trajectory.lapDuration() && !reached; t += 0.02)
    {
      const sim::Pose2d pose = trajectory.at(t);
      reached = (Eigen::Vector2d(pose.x, pose.y) - stand).norm() < 1.0 &&
                facing(pose, visits[v].look_direction) > std::cos(M_PI / 180.0);
    }
    EXPECT_TRUE(reached) << "visit " << v;
  }
  // Nearest first: the block's north side (nearer the lanes' end) or the corner, whichever is nearer; the last one
  // driven is where the route ends.
  const Eigen::Vector2d last = route->back();
  const size_t last_visit = (last - visits[0].standpoint).norm() < (last - visits[1].standpoint).norm() ? 0 : 1;
  EXPECT_LT((last - visits[last_visit].standpoint).norm(), 1.0);
  EXPECT_GT(facing(end, visits[last_visit].look_direction), std::cos(M_PI / 180.0));
  // The corner's floor ahead is blocked, so its sweep ends at the free cell nearest its standpoint.
  const Eigen::Vector2d corner_cell(0.45, 0.45);
  EXPECT_TRUE(std::any_of(route->begin() + static_cast<long>(lanes->size()), route->end(),
                          [&](const Eigen::Vector2d& p) { return (p - corner_cell).norm() < 0.15; }));
}

// The hints of fresh set F's corridor 284204 (2026-12-04): three standpoints of one camera 0.3-0.6 m apart across a
// narrow corridor, and a fourth. Their visits put two waypoints within a millimetre of each other, which the world
// file (millimetres) wrote as one repeated waypoint and parseWorld refused ("repeats the previous waypoint").
TEST(WorldGenerator, VisitsCloseTogetherMakeAValidWorld)
{
  sim::WorldGeneratorOptions options;
  options.seed = 284204;
  options.max_route_s = 120.0;
  options.view_leg_m = 4.0;
  options.look_around_spacing_m = 3.0;
  options.visits = {{{18.467, 1.027}, {1.0, -0.0040}},
                    {{18.467, 1.341}, {1.0, -0.0029}},
                    {{18.467, 1.957}, {1.0, -0.0014}},
                    {{3.932, 1.167}, {0.9708, 0.2399}}};
  const auto world = sim::generateWorld(options);
  ASSERT_TRUE(world) << world.error().describe();
  const auto& w = world->world.route.waypoints;
  for (size_t k = 1; k < w.size(); ++k)
    EXPECT_GE((w[k] - w[k - 1]).norm(), 1e-3) << "waypoint " << k;
}

// generate_world with visits: the same building, cameras and route first, the visits after, and a longer drive.
TEST(WorldGenerator, VisitsExtendTheRouteAndKeepEverythingElse)
{
  sim::WorldGeneratorOptions options;
  options.seed = 3;
  options.kind = sim::BuildingKind::kCorridor;
  options.max_route_s = 35.0;
  const auto plain = sim::generateWorld(options);
  ASSERT_TRUE(plain);
  const Eigen::Vector2d first = plain->world.route.waypoints.front();
  options.visits = {{first + Eigen::Vector2d(0.3, 0.3), Eigen::Vector2d(0, 1)}};
  const auto visiting = sim::generateWorld(options);
  ASSERT_TRUE(visiting) << visiting.error().describe();
  EXPECT_EQ(visiting->visits_skipped, 0u);
  EXPECT_NEAR(visiting->route_before_visits_s, plain->route_duration_s, 0.1);
  EXPECT_GT(visiting->route_duration_s, plain->route_duration_s + 2.0);
  const auto& a = plain->world.route.waypoints;
  const auto& b = visiting->world.route.waypoints;
  ASSERT_GT(b.size(), a.size());
  for (size_t k = 0; k < a.size(); ++k)
    EXPECT_LT((a[k] - b[k]).norm(), 1e-9);
  EXPECT_EQ(visiting->cameras_yaml, plain->cameras_yaml);
  ASSERT_EQ(visiting->world.fixed_cameras.size(), plain->world.fixed_cameras.size());
  EXPECT_EQ(visiting->world.surfaces.size(), plain->world.surfaces.size());
  // Visits only (a second recording): the same drive to the visits, from where the route ends.
  options.visits_only = true;
  const auto second = sim::generateWorld(options);
  ASSERT_TRUE(second) << second.error().describe();
  const auto& c = second->world.route.waypoints;
  ASSERT_EQ(c.size(), b.size() - a.size() + 1);
  for (size_t k = 0; k < c.size(); ++k)
    EXPECT_LT((c[k] - b[a.size() - 1 + k]).norm(), 1e-9) << k;
  EXPECT_EQ(second->route_before_visits_s, 0.0);
  // The same drive, but for the turn at the route's end (the second recording starts facing its first leg): at
  // most half a turn at 40 deg/s.
  const double visits_s = visiting->route_duration_s - visiting->route_before_visits_s;
  EXPECT_LE(second->route_duration_s, visits_s + 0.1);
  EXPECT_GE(second->route_duration_s, visits_s - 180.0 / 40.0 - 0.1);
  EXPECT_EQ(second->cameras_yaml, plain->cameras_yaml);
}

namespace
{
// The world file with one line of its xtion block ("  key: ...") replaced.
std::string withXtionLine(std::string yaml, const std::string& key, const std::string& value)
{
  const size_t at = yaml.find("  " + key + ": ", yaml.find("xtion:\n"));
  if (at == std::string::npos)
    return "";
  return yaml.replace(at, yaml.find('\n', at) - at, "  " + key + ": " + value);
}
}  // namespace

// A given Xtion tilt or height (generate_world --xtion-tilt, --xtion-height: the mount advice followed) changes that
// line of the world file and nothing else: the same building, cameras, route and the rest of the mount.
TEST(WorldGenerator, AGivenXtionMountChangesOnlyItsLine)
{
  sim::WorldGeneratorOptions options;
  options.seed = 5;
  options.max_route_s = 35.0;
  const auto drawn = sim::generateWorld(options);
  ASSERT_TRUE(drawn);
  options.xtion_tilt_deg = 7.5;
  const auto tilted = sim::generateWorld(options);
  ASSERT_TRUE(tilted) << tilted.error().describe();
  EXPECT_EQ(tilted->world.xtion.tilt_deg, 7.5);
  EXPECT_NE(drawn->world.xtion.tilt_deg, 7.5);
  EXPECT_EQ(tilted->world.xtion.mount_height_m, drawn->world.xtion.mount_height_m);
  EXPECT_EQ(tilted->cameras_yaml, drawn->cameras_yaml);
  EXPECT_EQ(tilted->world_yaml, withXtionLine(drawn->world_yaml, "tilt_deg", "7.5"));

  options.xtion_tilt_deg.reset();
  options.xtion_height_m = 1.4;
  const auto raised = sim::generateWorld(options);
  ASSERT_TRUE(raised) << raised.error().describe();
  EXPECT_EQ(raised->world.xtion.mount_height_m, 1.4);
  EXPECT_NE(drawn->world.xtion.mount_height_m, 1.4);
  EXPECT_EQ(raised->world.xtion.tilt_deg, drawn->world.xtion.tilt_deg);
  EXPECT_EQ(raised->cameras_yaml, drawn->cameras_yaml);
  EXPECT_EQ(raised->world_yaml, withXtionLine(drawn->world_yaml, "mount_height", "1.4"));
}
