// simulate_survey: records a simulated survey of a world into a rosbag, with the ground truth beside it.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "command_line.h"
#include "insitu_calibration/ros/survey_bag_writer.h"
#include "insitu_calibration/simulation/survey.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const char* kUsage =
    R"(Usage: simulate_survey --world WORLD.yaml --out survey.bag --seed N [--duration S] [--rate HZ] [options]

Simulates a survey of a world: the robot drives its route with its Xtion (RGB 640x480 rgb8 and registered depth
16UC1 in mm, openni2_launch's topics and frames) while the fixed cameras record through their true division model,
and writes an LZ4-compressed bag. Same seed, same bag. Beside the bag, in <bag name>_truth/: <camera>.yaml (the true
calibration of every fixed camera, calibrate_lines' format), edges.yaml (the world's true 3D edges in map) and
survey.yaml (what was simulated).

Topics: /camera/rgb/image_raw, /camera/rgb/camera_info, /camera/depth_registered/image_raw,
/camera/depth_registered/camera_info, /tf (map -> odom -> base_link), /tf_static (base_link -> camera_link ->
camera_rgb_frame -> camera_rgb_optical_frame, and the depth frames), /fixed/<name>/image_raw and
/fixed/<name>/camera_info (nominal size only) for every fixed camera.

Options:
  --world FILE        world file (config/worlds/*.yaml; format in docs/simulator.md)
  --out FILE          the bag to write
  --seed N            seed of every random choice (sensor noise, odometry drift); required
  --duration S        survey length in seconds (default 40; at most 3600, and 20000 RGB-D frames)
  --rate HZ           RGB-D frame rate (default 5, at most 60); /tf runs at a multiple of it, at least 20 Hz
  --fixed-rate HZ     rate of every fixed camera, at most 60 (default: each camera's rate in the world file)
  --start-time SEC    stamp of the start, seconds since the epoch, 0 .. 4e9 (default 1700000000)
  --no-depth-noise    exact depth (rounded to mm; no-return rules kept)
  --no-image-noise    no sensor noise on the fixed cameras (and the Xtion RGB)
  --odom-drift        odom -> base_link drifts (random walk), map -> odom compensates it
  --localization-error SIGMA_M,SIGMA_DEG[,TAU_S]
                      the localiser errs: map -> base_link in /tf is the true pose moved by a smooth random error
                      in x, y (sigma SIGMA_M) and yaw (SIGMA_DEG), correlation time TAU_S (default 5 s), as an
                      AMCL-like 2D-lidar localiser wanders (on map -> odom). The truth keeps the true poses;
                      <bag>_truth/localization.yaml has the error at every RGB-D frame. E.g. 0.02,0.5
  --benchmark         render the survey without writing anything, and print the time per frame
  --quiet             print only errors
  -h, --help          this text

Exit status: 0 success, 1 simulation or writing failed, 2 bad command line or world file.
)";

constexpr double kMaxStartTimeS = 4e9;    // ros::Time's seconds are unsigned 32-bit
constexpr double kMaxDurationS = 3600.0;  // documented limits of a simulated survey
constexpr double kMaxRateHz = 60.0;       // RGB-D and fixed-camera frame rates
constexpr double kMaxFrames = 20000.0;    // RGB-D frames (duration x rate)

// The command line's numbers within the documented limits, and the output a file name; also removes the unfinished
// <out>.active of an earlier run that was killed (writeSurveyBag writes there and renames at the end).
std::string checkRunOptions(const ic::CommandLine& cli, const sim::SimulationOptions& options)
{
  const auto within = [](double v, double low, double high) { return std::isfinite(v) && v >= low && v <= high; };
  if (options.start_time_ns < 0)
    return "--start-time must be within 0 .. 4e9 seconds since the epoch";
  if (!within(options.duration_s, 1e-3, kMaxDurationS) || !within(options.rate_hz, 1e-3, kMaxRateHz) ||
      options.duration_s * options.rate_hz > kMaxFrames)
    return "--duration must be within 0.001 .. 3600 s, --rate within 0.001 .. 60 Hz, and duration x rate at most "
           "20000 frames";
  if (options.fixed_rate_hz && !within(*options.fixed_rate_hz, 1e-3, kMaxRateHz))
    return "--fixed-rate must be within 0.001 .. 60 Hz";
  if (!cli.has("out"))
    return {};
  const std::string out = cli.value("out");
  std::error_code ec;
  if (out.empty() || std::filesystem::is_directory(out, ec))
    return "--out must name a file (got '" + out + "')";
  if (std::filesystem::exists(out + ".active", ec) && std::filesystem::remove(out + ".active", ec))
    std::cerr << "simulate_survey: removed " << out << ".active, left unfinished by an earlier run\n";
  return {};
}

int fail(const std::string& message, int status)
{
  std::cerr << "simulate_survey: " << message << "\n";
  return status;
}

void printTimings(const sim::SurveySimulator& survey, double wall_s)
{
  const sim::SurveyTimings& t = survey.timings();
  const double rgbd_s = t.xtion_render_s + t.xtion_sensor_s;
  std::printf("| RGB-D frames (640x480) | %d | %.2f s | %.1f ms/frame (render %.1f + sensor %.1f) | %.1f fps |\n",
              t.xtion_frames, rgbd_s, 1e3 * rgbd_s / std::max(1, t.xtion_frames),
              1e3 * t.xtion_render_s / std::max(1, t.xtion_frames),
              1e3 * t.xtion_sensor_s / std::max(1, t.xtion_frames), t.xtion_frames / std::max(1e-9, rgbd_s));
  std::printf("| fixed cameras, clean renders | %zu | %.2f s | | |\n", survey.world().fixed_cameras.size(),
              t.fixed_render_s);
  std::printf("| fixed camera frames (noise) | %d | %.2f s | %.1f ms/frame | |\n", t.fixed_frames, t.fixed_noise_s,
              1e3 * t.fixed_noise_s / std::max(1, t.fixed_frames));
  std::printf("| whole survey | %d RGB-D + %d fixed | %.2f s | %.1f ms per RGB-D frame | %.1f RGB-D fps |\n",
              t.xtion_frames, t.fixed_frames, wall_s, 1e3 * wall_s / std::max(1, t.xtion_frames),
              t.xtion_frames / std::max(1e-9, wall_s));
}

// The simulation's options from the command line; an empty string, or what is wrong.
std::string readSimulationOptions(ic::CommandLine& cli, sim::SimulationOptions* options)
{
  options->duration_s = cli.number("duration", options->duration_s);
  options->rate_hz = cli.number("rate", options->rate_hz);
  options->seed = static_cast<uint64_t>(cli.number("seed", 0));
  if (cli.has("fixed-rate"))
    options->fixed_rate_hz = cli.number("fixed-rate", 1.0);
  const double start_time_s = cli.number("start-time", 1.7e9);
  // ros::Time holds unsigned 32-bit seconds; checked in checkRunOptions before it is used.
  options->start_time_ns =
      start_time_s >= 0.0 && start_time_s <= kMaxStartTimeS ? static_cast<int64_t>(start_time_s) * 1000000000LL : -1;
  options->depth_noise = !cli.flag("no-depth-noise");
  options->image_noise = !cli.flag("no-image-noise");
  options->odom_drift = cli.flag("odom-drift");
  if (!cli.has("localization-error"))
    return {};
  std::vector<double> v;
  std::stringstream list(cli.value("localization-error"));
  for (std::string item; std::getline(list, item, ',');)
    v.push_back(std::atof(item.c_str()));
  if (v.size() < 2 || v.size() > 3)
    return "--localization-error takes SIGMA_M,SIGMA_DEG[,TAU_S]";
  options->localization_sigma_m = v[0];
  options->localization_sigma_deg = v[1];
  if (v.size() == 3)
    options->localization_tau_s = v[2];
  return {};
}

// The bag and its ground truth; the exit status.
int writeBagAndTruth(const sim::SurveySimulator& survey, const std::string& out, bool quiet)
{
  const auto summary = ic::writeSurveyBag(survey, out, [&](size_t done, size_t total) {
    if (!quiet && (done % 50 == 0 || done == total))
      std::printf("  %zu/%zu RGB-D frames\n", done, total);
  });
  if (!summary)
    return fail(summary.error().describe(), 1);
  const std::string truth = sim::truthDirectoryFor(out);
  if (const auto s = sim::writeGroundTruth(survey, truth, ic::surveyTopics(survey.world())); !s)
    return fail(s.error().describe(), 1);
  if (!quiet)
  {
    std::printf("wrote %s: %zu messages, %.1f MB, in %.1f s (bag writing %.1f s); ground truth in %s/\n", out.c_str(),
                summary->messages, summary->bytes / 1e6, summary->total_s, summary->bag_write_s, truth.c_str());
    std::printf("| stage | count | time | per frame | rate |\n|---|---|---|---|---|\n");
    printTimings(survey, summary->total_s);
  }
  return 0;
}
}  // namespace

int main(int argc, char** argv)
{
  ic::CommandLine cli(argc, argv,
                      {"world", "out", "seed", "duration", "rate", "fixed-rate", "start-time", "localization-error"},
                      {"no-depth-noise", "no-image-noise", "odom-drift", "benchmark", "quiet"});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  sim::SimulationOptions options;
  if (const std::string problem = readSimulationOptions(cli, &options); !problem.empty())
    return fail(problem + "\n\n" + std::string(kUsage), 2);
  const bool benchmark = cli.flag("benchmark");
  if (!cli.error().empty() || !cli.positional().empty() || !cli.has("world") || !cli.has("seed") ||
      (!benchmark && !cli.has("out")))
    return fail((!cli.error().empty()        ? cli.error()
                 : !cli.positional().empty() ? "unexpected argument '" + cli.positional()[0] + "'"
                                             : std::string("--world, --seed and --out are required")) +
                    "\n\n" + kUsage,
                2);
  if (const std::string problem = checkRunOptions(cli, options); !problem.empty())
    return fail(problem, 2);
  auto world = sim::loadWorldFile(cli.value("world"));
  if (!world)
    return fail(world.error().describe(), 2);
  auto survey = sim::SurveySimulator::create(std::move(*world), options);
  if (!survey)
    return fail(survey.error().describe(), 2);
  const bool quiet = cli.flag("quiet");
  if (!quiet)
    std::printf("simulate_survey: world %s, seed %llu, %.1f s at %.1f Hz (%zu RGB-D frames, tf at %.1f Hz)\n",
                survey->world().name.c_str(), static_cast<unsigned long long>(options.seed), options.duration_s,
                options.rate_hz, survey->xtionFrameCount(), survey->tfRateHz());
  if (!benchmark)
    return writeBagAndTruth(*survey, cli.value("out"), quiet);
  const auto start = std::chrono::steady_clock::now();
  sim::renderWholeSurvey(*survey);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("| stage | count | time | per frame | rate |\n|---|---|---|---|---|\n");
  printTimings(*survey, wall);
  return 0;
}
