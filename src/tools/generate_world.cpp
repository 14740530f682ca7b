// generate_world: a procedural building for the simulator (a world file) and its installer's camera priors.
#include <cmath>
#include <cstdio>
#include <optional>
#include <iostream>

#include "command_line.h"
#include "insitu_calibration/io/atomic_file.h"
#include "insitu_calibration/simulation/world_generator.h"
#include "insitu_calibration/survey/survey_hint_file.h"

namespace sim = insitu_calibration::simulation;
using insitu_calibration::Status;
using insitu_calibration::writeFileAtomically;

namespace
{
const char* kUsage = R"(Usage: generate_world --seed N --out WORLD.yaml [options]

Writes a building drawn from the seed in the simulator's world format (docs/simulator.md): a room, hall, corridor
with rooms, or office, with openings, columns, steps, furniture and textures; 2-3 fixed cameras placed as installers
place them (corners and walls, 2.4-5 m high, horizontal FOV 30-110 deg, division distortion 0-60 px at the corners,
principal point up to 3 % off centre, 640x480 to 2560x1440, roll up to 3 deg); a robot route that covers the floor
in lanes 0.45 m clear of everything; the Xtion's mount varied (height 0.3-1.5 m, tilt -20..15 deg). Same seed, same
files. Prints the building, its cameras and the route's duration.

Options:
  --seed N                 the building (required)
  --kind K                 room | hall | corridor | office (default: drawn from the seed)
  --out FILE               the world file
  --cameras-out FILE       also the installer's priors in config/cameras.yaml's format
  --prior-error M,DEG,FOV  how far each prior is from the truth: position (m, random direction), viewing direction
                           (deg, random axis) and horizontal field of view (relative, random sign); the priors'
                           sigmas are the same sizes (default 0.5,10,0.2)
  --max-route-s S          keep the drive under S seconds (lanes and look-arounds further apart, the route cut;
                           default 0: cover the floor in lanes 1.5 m apart)
  --look-around-spacing M  a look-around (the robot drives a 0.3 m square, turning in place at each corner, so the
                           Xtion faces every wall) about every M metres along the lanes (default 0: none; 3 is
                           an operator's habit)
  --view-leg M             the route starts with a drive of up to M metres per camera from under its installer prior
                           along the prior's viewing direction, so the Xtion sees what the camera sees, as an operator
                           surveying for the cameras would (default 0: none; try 4)
  --visit-hints F[,F...]   after the route, drive to each region of these survey hints (calibrate_survey's
                           DIR/<camera>_survey_hint.yaml, nearest first): the shortest free path to its standpoint,
                           then three 0.3 m legs turned +30, -30 and 0 deg from its look direction, so the Xtion
                           sweeps where the hint says and ends looking there. The building, cameras and the route
                           before the visits are unchanged (give the same --seed and options as the first time)
  --visits-only            with --visit-hints: the route is only the drive to the visits, from where the route
                           ends (a second recording, after the first drive; calibrate_survey FIRST.bag SECOND.bag)
  --xtion-tilt DEG         the Xtion tilted DEG above the horizontal instead of the drawn tilt (the building, its
                           cameras and route and the mount's height unchanged); "advised": of the pitches the
                           --visit-hints files advise for regions out of the Xtion's reach (their
                           xtion_pitch_deg), the one that serves most of their image lines (pitches within 5 deg
                           one mount), the drawn tilt if none does
  --xtion-height M         the Xtion's mount M metres above the floor instead of the drawn height (everything else
                           unchanged); "advised": the height of the mount the --visit-hints files advise (the
                           xtion_height_m of the region whose pitch --xtion-tilt advised takes), the drawn height
                           where that mount keeps it
  --appearance A           realistic (default): sensor blur, vignetting, exposure and white balance differing per
                           camera, JPEG on the fixed cameras, Xtion RGB noise, flying pixels, low-frequency depth
                           error and RGB-to-depth misregistration (docs/simulator.md, "appearance"); plain: none of
                           these, as the hand-made worlds (the building is the same either way)
  -h, --help               this text

Example:
  generate_world --seed 101 --out /tmp/w.yaml --cameras-out /tmp/c.yaml --max-route-s 40
  simulate_survey --world /tmp/w.yaml --out /tmp/s.bag --duration 40
  calibrate_survey /tmp/s.bag --cameras /tmp/c.yaml --out-dir /tmp/out --truth-dir /tmp/s_truth
  # a camera refused: survey again with its hint followed (the duration printed by generate_world)
  generate_world --seed 101 --out /tmp/w2.yaml --max-route-s 40 --visit-hints /tmp/out/cam_a_survey_hint.yaml
)";

// The hint files, in order.
insitu_calibration::Expected<std::vector<insitu_calibration::SurveyHint>> readHints(
    const std::vector<std::string>& paths)
{
  std::vector<insitu_calibration::SurveyHint> hints;
  for (const std::string& path : paths)
  {
    auto hint = insitu_calibration::readSurveyHint(path);
    if (!hint)
      return hint.error();
    hints.push_back(std::move(*hint));
  }
  return hints;
}

// Every region of every hint, as a visit.
std::vector<sim::Visit> visitsOf(const std::vector<insitu_calibration::SurveyHint>& hints)
{
  std::vector<sim::Visit> visits;
  for (const auto& hint : hints)
    for (const auto& region : hint.regions)
      visits.push_back({region.standpoint, region.look_direction});
  return visits;
}

// --xtion-tilt (deg) and --xtion-height (m): a number within [low, high], or "advised": the hints' advised mount's
// (advisedXtionMount; nothing changes where the hints advise none, or keep the Xtion's height).
std::string parseXtionMount(const std::string& option, const std::string& text, const char* unit, double low,
                            double high, const std::vector<insitu_calibration::SurveyHint>& hints,
                            std::optional<double>* value)
{
  if (text == "advised")
  {
    if (hints.empty())
      return "--" + option + " advised needs --visit-hints";
    if (const auto mount = insitu_calibration::advisedXtionMount(hints))
      *value = option == "xtion-tilt" ? std::optional<double>(mount->pitch_deg) : mount->height_m;
    return "";
  }
  double number = 0.0;
  char extra = 0;
  if (std::sscanf(text.c_str(), "%lf%c", &number, &extra) != 1 || number < low || number > high)
  {
    char range[96];
    std::snprintf(range, sizeof(range), " must be %s between %g and %g or 'advised' (got '", unit, low, high);
    return "--" + option + range + text + "')";
  }
  *value = number;
  return "";
}

bool parsePriorError(const std::string& text, sim::PriorError* error)
{
  double m = 0, d = 0, f = 0;
  char extra = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &m, &d, &f, &extra) != 3 || m < 0 || d < 0 || f < 0 || f >= 1)
    return false;
  *error = {m, d, f};
  return true;
}
}  // namespace

// The generator's options from the command line; the problem with them, empty when they are usable.
std::string parseOptions(insitu_calibration::CommandLine& cli, sim::WorldGeneratorOptions* options)
{
  options->seed = static_cast<uint64_t>(cli.number("seed", -1));
  options->max_route_s = cli.number("max-route-s", 0.0);
  options->look_around_spacing_m = cli.number("look-around-spacing", options->look_around_spacing_m);
  options->view_leg_m = cli.number("view-leg", options->view_leg_m);
  std::string problem = cli.error();
  if (problem.empty() && (!cli.has("seed") || !cli.has("out")))
    problem = "--seed and --out are required";
  if (problem.empty() && cli.has("kind"))
  {
    const auto kind = sim::parseBuildingKind(cli.value("kind"));
    if (kind)
      options->kind = *kind;
    else
      problem = kind.error().message();
  }
  if (problem.empty() && cli.has("appearance"))
  {
    const std::string look = cli.value("appearance");
    if (look == "plain" || look == "realistic")
      options->realistic_appearance = look == "realistic";
    else
      problem = "--appearance must be plain or realistic (got '" + look + "')";
  }
  if (problem.empty() && cli.has("prior-error") && !parsePriorError(cli.value("prior-error"), &options->prior_error))
    problem = "--prior-error needs three non-negative numbers M,DEG,FOV (FOV < 1), e.g. 0.5,10,0.2";
  if (problem.empty() &&
      (options->max_route_s < 0.0 || options->look_around_spacing_m < 0.0 || options->view_leg_m < 0.0))
    problem = "--max-route-s, --look-around-spacing and --view-leg must be 0 or positive";
  std::vector<insitu_calibration::SurveyHint> hints;
  if (problem.empty() && cli.has("visit-hints"))
  {
    const auto read = readHints(cli.items("visit-hints"));
    if (read)
      hints = *read;
    else
      problem = "--visit-hints: " + read.error().message();
    options->visits = visitsOf(hints);
  }
  options->visits_only = cli.flag("visits-only");
  if (problem.empty() && options->visits_only && hints.empty())
    problem = "--visits-only needs --visit-hints";
  if (problem.empty() && cli.has("xtion-tilt"))
    problem =
        parseXtionMount("xtion-tilt", cli.value("xtion-tilt"), "degrees", -60.0, 60.0, hints, &options->xtion_tilt_deg);
  if (problem.empty() && cli.has("xtion-height"))
    problem =
        parseXtionMount("xtion-height", cli.value("xtion-height"), "metres", 0.1, 3.0, hints, &options->xtion_height_m);
  return problem;
}

// What was generated: the building, its route (and visits) and its fixed cameras.
void printSummary(const sim::WorldGeneratorOptions& options, const sim::GeneratedWorld& world)
{
  std::printf("%s (seed %llu): %s; %zu surfaces, route %zu waypoints, %.1f s\n", world.world.name.c_str(),
              static_cast<unsigned long long>(options.seed), sim::buildingKindName(world.kind),
              world.world.surfaces.size(), world.world.route.waypoints.size(), world.route_duration_s);
  if (!options.visits.empty())
    std::printf("  visits: %zu of %zu driven after the route's %.1f s (%.1f s more)\n",
                options.visits.size() - world.visits_skipped, options.visits.size(), world.route_before_visits_s,
                world.route_duration_s - world.route_before_visits_s);
  std::printf("  xtion %.2f m high (%s), tilted %+.1f deg (%s)\n", world.world.xtion.mount_height_m,
              options.xtion_height_m ? "given" : "drawn", world.world.xtion.tilt_deg,
              options.xtion_tilt_deg ? "given" : "drawn");
  for (const auto& c : world.world.fixed_cameras)
  {
    const auto& k = c.camera.intrinsics();
    const Eigen::Vector3d p = c.camera.pose().center();
    std::printf("  %s %dx%d fx %.1f (HFOV %.1f deg) at %.2f %.2f %.2f, lambda %.3g\n", c.name.c_str(), c.width,
                c.height, k.fx, 2.0 * std::atan(0.5 * c.width / k.fx) * 180.0 / M_PI, p.x(), p.y(), p.z(),
                c.camera.distortion().lambda);
  }
}

int main(int argc, char** argv)
{
  insitu_calibration::CommandLine cli(
      argc, argv,
      {"seed", "kind", "out", "cameras-out", "prior-error", "max-route-s", "look-around-spacing", "view-leg",
       "appearance", "visit-hints", "xtion-tilt", "xtion-height"},
      {"visits-only"});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  sim::WorldGeneratorOptions options;
  const std::string problem = parseOptions(cli, &options);
  if (!problem.empty())
  {
    std::cerr << "generate_world: " << problem << "\n\n" << kUsage;
    return 2;
  }
  const auto world = sim::generateWorld(options);
  if (!world)
  {
    std::cerr << "generate_world: " << world.error().describe() << "\n";
    return 1;
  }
  // Each file whole or not at all (written beside its place, then renamed).
  for (const auto& [option, text] : {std::pair{"out", &world->world_yaml}, {"cameras-out", &world->cameras_yaml}})
    if (cli.has(option))
      if (const Status written = writeFileAtomically(cli.value(option), *text); !written)
      {
        std::cerr << "generate_world: " << written.error().describe() << "\n";
        return 1;
      }
  printSummary(options, *world);
  return 0;
}
