// Procedural buildings for the simulator (generate_world): a world file in the format of config/worlds/*.yaml from a
// seed, with fixed cameras placed as installers place them and the installers' priors in config/cameras.yaml's
// format, so that the survey pipeline can be measured on buildings nobody tuned it on (scripts/bench_generalisation).
//
// Appearance: realistic by default (see WorldGeneratorOptions::realistic_appearance).
// Kinds: room (4 x 4 x 2.6 m to 10 x 8 x 3.2 m), hall (12 x 8 x 4 m to 20 x 12 x 6 m, columns, a reception desk, a
// stage with steps), corridor (15-25 m long, rooms off it through doorways) and office (desk rows, screens,
// cabinets). Doorways open onto small vestibules so that nothing is seen through them but more building.
// Cameras (2-3): in corners or on walls 2.4-5 m high (below the ceiling), looking at a point of the floor area;
// horizontal field of view 30-110 deg, division distortion from none to 60 px at the corners (more for wider lenses),
// principal point up to 3 % off centre, 640x480 to 2560x1440, roll up to 3 deg. The robot's route covers the floor
// in lanes and keeps 0.45 m from walls and obstacles; the Xtion's mount varies (height 0.3-1.5 m, tilt -20..15 deg).
#ifndef INSITU_CALIBRATION_SIMULATION_WORLD_GENERATOR_H
#define INSITU_CALIBRATION_SIMULATION_WORLD_GENERATOR_H

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "insitu_calibration/error.h"
#include "insitu_calibration/simulation/route_planner.h"
#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace simulation
{
enum class BuildingKind
{
  kRoom,
  kHall,
  kCorridor,
  kOffice
};

const char* buildingKindName(BuildingKind kind);
Expected<BuildingKind> parseBuildingKind(const std::string& name);  // room | hall | corridor | office

// How far the installer's prior is from the truth: the position moved this far in a random direction, the viewing
// direction turned this much about a random axis across it, the horizontal field of view scaled by 1 +- this. The
// prior's sigmas are set to the same sizes.
struct PriorError
{
  double position_m = 0.5;
  double direction_deg = 10.0;
  double fov_relative = 0.2;
};

struct WorldGeneratorOptions
{
  uint64_t seed = 1;
  std::optional<BuildingKind> kind;  // default: drawn from the seed
  PriorError prior_error;
  double max_route_s = 0.0;  // > 0: lanes further apart (and the route cut) to keep the drive this short
  double speed = 0.45;       // robot speed along the legs, m/s
  // Look-arounds (the robot drives a 0.3 m square, turning in place at its corners) about this far apart along the
  // lanes, spread with the lanes to fit max_route_s; 0: lanes only. An operator surveying for fixed cameras turns
  // the Xtion to every wall: along lanes alone it sees the walls beside them only at grazing angles.
  double look_around_spacing_m = 0.0;
  // > 0: the route starts with a drive of up to this length per fixed camera, from under its installer prior along
  // its prior viewing direction (what an operator surveying for the cameras does; the lanes follow); 0: lanes only.
  double view_leg_m = 0.0;
  // Realistic sensors (the world file's appearance block: blur, vignetting, exposure and white balance drawn per
  // camera, JPEG on the fixed cameras, Xtion RGB noise, flying pixels, low-frequency depth error, RGB-to-depth
  // misregistration); false: the plain appearance of the hand-made worlds. Drawn from its own stream of the seed, so
  // the building is the same either way.
  bool realistic_appearance = true;
  // Driven after the route (cut to max_route_s or not): to each standpoint, then a look along its direction
  // (route_planner.h, appendVisits), e.g. from refused cameras' survey hints (generate_world --visit-hints). The
  // building, its cameras and the route before the visits are the same as without them.
  std::vector<Visit> visits;
  // With visits: the route is only the drive to them from where the route ends (a second recording of the survey,
  // after the first drive: generate_world --visits-only).
  bool visits_only = false;
  // The Xtion's tilt (deg above the horizontal) instead of the drawn one, e.g. as refused cameras' survey hints
  // advise (generate_world --xtion-tilt); everything else, the mount's height included, is drawn as without it.
  std::optional<double> xtion_tilt_deg;
  // The Xtion's mount height above the floor (m) instead of the drawn one (generate_world --xtion-height), as a
  // hint's mount advice may ask; the tilt and everything else as without it.
  std::optional<double> xtion_height_m;
};

struct GeneratedWorld
{
  BuildingKind kind = BuildingKind::kRoom;
  std::string world_yaml;    // the world file
  std::string cameras_yaml;  // the installer's priors (config/cameras.yaml format)
  World world;               // world_yaml as parseWorld reads it
  double route_duration_s = 0.0;
  double route_before_visits_s = 0.0;  // the drive without the visits (0 with visits_only)
  size_t visits_skipped = 0;           // visits with no free standpoint or look (appendVisits)
};

// Same options, same files (byte for byte). Errors only when the generated file fails to parse (a bug).
Expected<GeneratedWorld> generateWorld(const WorldGeneratorOptions& options);

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_WORLD_GENERATOR_H
