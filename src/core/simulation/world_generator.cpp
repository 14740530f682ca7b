#include "insitu_calibration/simulation/world_generator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

#include "generator_layouts.h"
#include "insitu_calibration/simulation/trajectory.h"

namespace insitu_calibration
{
namespace simulation
{
namespace
{
using generator::num;
using generator::Rng;
using generator::vec;
using generator::vec3;
using V2 = Eigen::Vector2d;
using V3 = Eigen::Vector3d;
constexpr double kPi = 3.14159265358979323846;

struct PlacedCamera
{
  std::string name;
  int width = 0, height = 0;
  double fx = 0.0, cx = 0.0, cy = 0.0, corner_px = 0.0, roll_deg = 0.0;
  V3 position, target;
};

// Whether the segment a -> b passes through an axis-aligned box (slab test).
bool segmentHitsBox(const V3& a, const V3& b, const generator::Box3& box)
{
  double t0 = 0.0, t1 = 1.0;
  const V3 d = b - a;
  for (int k = 0; k < 3; ++k)
  {
    if (std::abs(d[k]) < 1e-12)
    {
      if (a[k] < box.min[k] || a[k] > box.max[k])
        return false;
      continue;
    }
    double lo = (box.min[k] - a[k]) / d[k], hi = (box.max[k] - a[k]) / d[k];
    if (lo > hi)
      std::swap(lo, hi);
    t0 = std::max(t0, lo);
    t1 = std::min(t1, hi);
    if (t0 > t1)
      return false;
  }
  return true;
}

bool clearView(const generator::Scene& scene, const V3& from, const V3& to)
{
  for (const auto& box : scene.solids)
    if (segmentHitsBox(from, to, box))
      return false;
  return true;
}

// An installer's camera at a site: a height under the ceiling, aimed at a visible point of the floor area at least
// 2 m away and 10-60 degrees down; lens, sensor and mounting drawn from the ranges.
std::optional<PlacedCamera> placeCamera(const generator::Layout& layout, const V2& site, Rng& rng)
{
  static const int kSizes[][2] = {{640, 480}, {800, 600}, {1280, 720}, {1280, 960}, {1920, 1080}, {2560, 1440}};
  const double top = std::min(5.0, layout.ceiling_height - 0.12);
  PlacedCamera c;
  c.position = V3(site.x(), site.y(), top > 2.4 ? rng.uniform(2.4, top) : top);
  const Eigen::AlignedBox2d& area = layout.scene.plan.walkable;
  for (int attempt = 0; attempt < 60; ++attempt)
  {
    const V3 target(rng.uniform(area.min().x() + 0.5, area.max().x() - 0.5),
                    rng.uniform(area.min().y() + 0.5, area.max().y() - 0.5), rng.uniform(0.0, 1.2));
    const double horizontal = (target - c.position).head<2>().norm();
    const double down = std::atan2(c.position.z() - target.z(), horizontal) * 180.0 / kPi;
    if (horizontal < 2.0 || down < 10.0 || down > 60.0 || !clearView(layout.scene, c.position, target))
      continue;
    c.target = target;
    const auto& size = kSizes[rng.integer(0, 5)];
    c.width = size[0];
    c.height = size[1];
    const double fov = rng.uniform(30.0, 110.0) * kPi / 180.0;
    c.fx = 0.5 * c.width / std::tan(0.5 * fov);
    c.cx = 0.5 * c.width - 0.5 + rng.uniform(-0.03, 0.03) * c.width;
    c.cy = 0.5 * c.height - 0.5 + rng.uniform(-0.03, 0.03) * c.height;
    c.corner_px = -rng.uniform(0.0, 60.0);
    c.roll_deg = rng.uniform(-3.0, 3.0);
    return c;
  }
  return std::nullopt;
}

std::vector<PlacedCamera> placeCameras(const generator::Layout& layout, Rng& rng)
{
  std::vector<V2> sites = layout.camera_sites;
  const int wanted = rng.integer(2, 3);
  std::vector<PlacedCamera> cameras;
  while (static_cast<int>(cameras.size()) < wanted && !sites.empty())
  {
    const size_t k = static_cast<size_t>(rng.integer(0, static_cast<int>(sites.size()) - 1));
    if (auto c = placeCamera(layout, sites[k], rng))
    {
      c->name = std::string("cam_") + static_cast<char>('a' + cameras.size());
      cameras.push_back(*c);
    }
    sites.erase(sites.begin() + static_cast<long>(k));
  }
  return cameras;
}

double routeDuration(const std::vector<V2>& waypoints, double speed)
{
  Route r;
  r.waypoints = waypoints;
  r.speed = speed;
  r.turn_rate_deg = 40.0;
  r.loop = false;
  return RouteTrajectory(r).lapDuration();
}

// The route up to where its drive takes `budget` seconds (the last leg shortened to fill it).
std::vector<V2> cutToDuration(std::vector<V2> route, double budget, double speed)
{
  V2 removed = route.back();
  while (route.size() > 2 && routeDuration(route, speed) > budget - 0.05)
  {
    removed = route.back();
    route.pop_back();
  }
  if (routeDuration(route, speed) <= budget - 0.05 && removed == route.back())
    return route;  // nothing to cut
  if (routeDuration(route, speed) > budget - 0.05)
  {
    removed = route.back();
    route.pop_back();
  }
  // Along the removed leg as far as the budget goes (bisection: the turn at its start counts too).
  double lo = 0.0, hi = 1.0;
  for (int k = 0; k < 30; ++k)
  {
    const double mid = 0.5 * (lo + hi);
    std::vector<V2> trial = route;
    trial.push_back(route.back() + mid * (removed - route.back()));
    // A margin for the waypoints' rounding in the world file.
    (routeDuration(trial, speed) <= budget - 0.05 ? lo : hi) = mid;
  }
  if (route.size() == 1 || lo * (removed - route.back()).norm() > 0.3)
    route.push_back(route.back() + lo * (removed - route.back()));
  return route;
}

// Lanes further apart until the drive fits the budget; if even the widest do not, the route cut where the budget
// ends: the cameras' view legs come first, then the lanes with their look-arounds.
Expected<std::vector<V2>> planRoute(const FloorPlan& plan, const WorldGeneratorOptions& options,
                                    const std::vector<ViewLeg>& view_legs)
{
  RoutePlanOptions route;
  route.look_around_spacing_m = options.look_around_spacing_m;
  route.view_legs = view_legs;
  Expected<std::vector<V2>> planned = Error(ErrorCode::kNoSolution, "no route");
  for (int round = 0; round < 8; ++round, route.lane_spacing_m *= 1.35)
  {
    planned = planCoverageRoute(plan, route);
    if (!planned || options.max_route_s <= 0.0 || routeDuration(*planned, options.speed) <= options.max_route_s)
      return planned;
  }
  return cutToDuration(*planned, options.max_route_s, options.speed);
}

std::string cameraYaml(const PlacedCamera& c)
{
  std::ostringstream out;
  out << "  - name: " << c.name << "\n    width: " << c.width << "\n    height: " << c.height
      << "\n    fx: " << num(c.fx) << "\n    fy: " << num(c.fx) << "\n    cx: " << num(c.cx)
      << "\n    cy: " << num(c.cy) << "\n    corner_displacement_px: " << num(c.corner_px)
      << "\n    position: " << vec3(c.position) << "\n    look_at: " << vec3(c.target)
      << "\n    roll_deg: " << num(c.roll_deg) << "\n";
  return out.str();
}

// The installer's prior: the truth moved, turned and its field of view scaled by the requested errors.
struct DrawnPrior
{
  std::string name;
  int width = 0, height = 0;
  V3 position, direction;
  double horizontal_fov_deg = 0.0;
};

DrawnPrior drawPrior(const PlacedCamera& c, const PriorError& error, Rng& rng)
{
  V3 shift(rng.gaussian(), rng.gaussian(), rng.gaussian());
  const V3 direction = (c.target - c.position).normalized();
  V3 across = direction.cross(V3(rng.gaussian(), rng.gaussian(), rng.gaussian())).normalized();
  const double fov = 2.0 * std::atan(0.5 * c.width / c.fx) * 180.0 / kPi;
  const double scaled = fov * (1.0 + (rng.chance(0.5) ? 1.0 : -1.0) * error.fov_relative);
  return {c.name,
          c.width,
          c.height,
          c.position + error.position_m * shift.normalized(),
          Eigen::AngleAxisd(error.direction_deg * kPi / 180.0, across) * direction,
          std::min(170.0, scaled)};
}

std::string priorYaml(const DrawnPrior& p, const PriorError& error)
{
  std::ostringstream out;
  out << "  - name: " << p.name << "\n    image_topic: /fixed/" << p.name << "/image_raw\n    image_width: " << p.width
      << "\n    image_height: " << p.height << "\n    prior:\n      position: " << vec3(p.position)
      << "\n      position_sigma_m: " << num(std::max(0.05, error.position_m))
      << "\n      direction: " << vec({p.direction.x(), p.direction.y(), p.direction.z()})
      << "\n      direction_sigma_deg: " << num(std::max(1.0, error.direction_deg))
      << "\n      horizontal_fov_deg: " << num(p.horizontal_fov_deg)
      << "\n      fov_sigma_relative: " << num(std::max(0.02, error.fov_relative)) << "\n";
  return out.str();
}

// An operator surveying for the cameras drives where each looks, in its direction, so that the Xtion sees what the
// camera sees: a view leg per camera from under its prior position along its prior viewing direction, the nearest
// camera next.
std::vector<ViewLeg> cameraViewLegs(const std::vector<DrawnPrior>& priors, double max_length_m)
{
  std::vector<ViewLeg> legs;
  for (const DrawnPrior& p : priors)
  {
    const V2 d = p.direction.head<2>();
    if (d.norm() > 1e-3)
      legs.push_back({p.position.head<2>() + 0.5 * d.normalized(), d.normalized(), max_length_m});
  }
  for (size_t k = 1; k < legs.size(); ++k)
  {
    const V2 from = legs[k - 1].start + max_length_m * legs[k - 1].direction;
    std::swap(legs[k], *std::min_element(legs.begin() + static_cast<long>(k), legs.end(),
                                         [&](const ViewLeg& a, const ViewLeg& b) {
                                           return (a.start - from).norm() < (b.start - from).norm();
                                         }));
  }
  return legs;
}

std::string cameraAppearanceYaml(Rng& rng, double blur_lo, double blur_hi, double vignetting_hi, double exposure,
                                 double white_balance, int jpeg_lo, int jpeg_hi)
{
  std::ostringstream out;
  out << "{blur_sigma_px: " << num(rng.uniform(blur_lo, blur_hi))
      << ", vignetting: " << num(rng.uniform(0.5 * vignetting_hi, vignetting_hi))
      << ", exposure: " << num(rng.uniform(1.0 - exposure, 1.0 + exposure)) << ", white_balance: "
      << vec({rng.uniform(1.0 - white_balance, 1.0 + white_balance), 1.0,
              rng.uniform(1.0 - white_balance, 1.0 + white_balance)});
  if (jpeg_hi > 0)
    out << ", jpeg_quality: " << rng.integer(jpeg_lo, jpeg_hi);
  return out.str() + "}";
}

// The realistic appearance (docs/simulator.md, "appearance"): the Xtion's and each fixed camera's optics, gains and
// compression drawn from a stream of their own, so that all cameras differ and the building does not change.
struct AppearanceYaml
{
  std::string world;                 // the world's appearance block and the Xtion's RGB noise
  std::vector<std::string> cameras;  // each fixed camera's appearance
};

AppearanceYaml drawAppearance(uint64_t seed, size_t cameras)
{
  Rng rng(seed, 0x6c6f6f6bULL);
  AppearanceYaml out;
  out.world = "appearance:\n  xtion_rgb: " + cameraAppearanceYaml(rng, 0.5, 0.9, 0.35, 0.15, 0.08, 0, 0) +
              "\n  depth: {flying_pixels: 0.5, flying_step_m: 0.04, low_frequency_coefficient: 0.0005, "
              "low_frequency_px: 80, misregistration_px: " +
              vec({rng.uniform(0.3, 0.9), rng.uniform(-0.5, 0.5)}) + "}\n";
  for (size_t k = 0; k < cameras; ++k)
    out.cameras.push_back(cameraAppearanceYaml(rng, 0.6, 1.3, 0.6, 0.3, 0.15, 70, 92));
  return out;
}

std::string worldYaml(const WorldGeneratorOptions& options, BuildingKind kind, const generator::Layout& layout,
                      const std::vector<V2>& route, const std::vector<PlacedCamera>& cameras, Rng& rng)
{
  std::ostringstream out;
  const std::string name = std::string("generated_") + buildingKindName(kind) + "_" + std::to_string(options.seed);
  out << "# Generated by generate_world --seed " << options.seed << " --kind " << buildingKindName(kind)
      << " (format: docs/simulator.md).\nname: " << name << "\ndescription: " << layout.description << ", "
      << cameras.size() << " fixed cameras.\n";
  AppearanceYaml look;
  if (options.realistic_appearance)
    look = drawAppearance(options.seed, cameras.size());
  out << look.world;
  const double ambient = rng.uniform(0.5, 0.7);
  out << "lighting: {ambient: " << num(ambient) << ", diffuse: " << num(1.0 - ambient)
      << ", direction: " << vec({rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.6, 1.2)}) << "}\nsurfaces:\n"
      << layout.scene.surfaces(options.realistic_appearance ? std::optional<uint64_t>(options.seed) : std::nullopt)
      << "route:\n  waypoints: [";
  // The file holds millimetres: a waypoint written within about one of the last one written is left out, since
  // parseWorld refuses a repeat (visits from standpoints close together across a corridor made one).
  std::optional<V2> last;
  for (const V2& p : route)
  {
    const V2 written(std::stod(num(p.x())), std::stod(num(p.y())));
    if (last && (written - *last).norm() < 1.5e-3)
      continue;
    out << (last ? ", " : "") << vec({p.x(), p.y()});
    last = written;
  }
  out << "]\n  speed: " << num(options.speed) << "\n  turn_rate_deg: 40\n  loop: false\n";
  const double mount_height = rng.uniform(0.3, 1.5), drawn_tilt = rng.uniform(-20.0, 15.0);
  out << "xtion:\n  mount_height: " << num(options.xtion_height_m.value_or(mount_height))
      << "\n  mount_forward: 0.1\n  tilt_deg: " << num(options.xtion_tilt_deg.value_or(drawn_tilt)) << "\n"
      << (options.realistic_appearance ? "  rgb_noise_sigma: 2\n" : "") << "fixed_cameras:\n";
  for (size_t k = 0; k < cameras.size(); ++k)
    out << cameraYaml(cameras[k]) << (look.cameras.empty() ? "" : "    appearance: " + look.cameras[k] + "\n");
  return out.str();
}
}  // namespace

const char* buildingKindName(BuildingKind kind)
{
  switch (kind)
  {
    case BuildingKind::kHall:
      return "hall";
    case BuildingKind::kCorridor:
      return "corridor";
    case BuildingKind::kOffice:
      return "office";
    default:
      return "room";
  }
}

Expected<BuildingKind> parseBuildingKind(const std::string& name)
{
  for (const BuildingKind k :
       {BuildingKind::kRoom, BuildingKind::kHall, BuildingKind::kCorridor, BuildingKind::kOffice})
    if (name == buildingKindName(k))
      return k;
  return Error(ErrorCode::kInvalidInput, "unknown building kind '" + name + "' (room, hall, corridor or office)");
}

Expected<GeneratedWorld> generateWorld(const WorldGeneratorOptions& options)
{
  Rng rng(options.seed, 0x776f726c64ULL), prior_rng(options.seed, 0x7072696f72ULL);
  GeneratedWorld out;
  out.kind = options.kind ? *options.kind : static_cast<BuildingKind>(rng.integer(0, 3));
  const generator::Layout layout = generator::buildLayout(out.kind, rng);
  const auto cameras = placeCameras(layout, rng);
  std::vector<DrawnPrior> priors;
  for (const auto& c : cameras)
    priors.push_back(drawPrior(c, options.prior_error, prior_rng));
  const auto route =
      planRoute(layout.scene.plan, options,
                options.view_leg_m > 0.0 ? cameraViewLegs(priors, options.view_leg_m) : std::vector<ViewLeg>{});
  if (!route)
    return Error(route.error().code(), std::string("generate_world: ") + route.error().message());
  out.route_before_visits_s = routeDuration(*route, options.speed);
  std::vector<V2> driven = *route;
  if (!options.visits.empty())
  {
    auto extended = appendVisits(layout.scene.plan, driven, options.visits, {}, &out.visits_skipped);
    if (!extended)
      return Error(extended.error().code(), std::string("generate_world: ") + extended.error().message());
    driven = std::move(*extended);
    if (options.visits_only)
    {
      if (driven.size() == route->size())
        return Error(ErrorCode::kInvalidInput, "generate_world: no visit could be driven (visits only)");
      driven.erase(driven.begin(), driven.begin() + static_cast<std::ptrdiff_t>(route->size() - 1));
      out.route_before_visits_s = 0.0;
    }
  }
  out.world_yaml = worldYaml(options, out.kind, layout, driven, cameras, rng);
  std::ostringstream prior_text;
  prior_text << "# Installer priors for the fixed cameras of generate_world --seed " << options.seed << " --kind "
             << buildingKindName(out.kind) << ": each off by " << num(options.prior_error.position_m) << " m, "
             << num(options.prior_error.direction_deg) << " deg and " << num(100.0 * options.prior_error.fov_relative)
             << " % field of view (format: config/cameras.yaml).\ncameras:\n";
  for (const auto& p : priors)
    prior_text << priorYaml(p, options.prior_error);
  out.cameras_yaml = prior_text.str();
  auto world = parseWorld(out.world_yaml, "generated world (seed " + std::to_string(options.seed) + ")");
  if (!world)
    return world.error();
  out.world = std::move(*world);
  out.route_duration_s = RouteTrajectory(out.world.route).lapDuration();
  return out;
}

}  // namespace simulation
}  // namespace insitu_calibration
