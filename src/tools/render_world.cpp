// render_world: renders views of a simulator world to PNG files, to look at a world while editing it.
#include <filesystem>
#include <cstdio>
#include <iostream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "command_line.h"
#include "insitu_calibration/simulation/sensor_models.h"
#include "insitu_calibration/simulation/survey.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const char* kUsage = R"(Usage: render_world --world WORLD.yaml --out-dir DIR [--time T]... [--seed N]

Renders every fixed camera of the world (clean, as the camera sees it through its division model) and the robot's
Xtion at the given survey times (seconds; default 0, 10, 20, 30), and writes PNG files into DIR:
  <camera>.png                 fixed camera, clean
  xtion_<T>.png                Xtion RGB
  xtion_<T>_depth.png          registered depth with noise, false colour (black: no return)
Prints the world's surfaces, the distortion of each fixed camera (displacement of the image corners) and its tilt.

Options:
  --world FILE     world file (config/worlds/*.yaml)
  --out-dir DIR    where to write (created if missing)
  --time T         survey time of an Xtion view, seconds (repeatable as --time=T1,T2,...)
  --seed N         noise seed (default 0)
  -h, --help       this text
)";

// Each fixed camera's clean image, with its distortion and tilt printed.
void renderFixedCameras(const sim::SurveySimulator& survey, const std::string& dir)
{
  const sim::World& w = survey.world();
  for (size_t c = 0; c < w.fixed_cameras.size(); ++c)
  {
    const sim::SimulatedFixedCamera& f = w.fixed_cameras[c];
    double corner = 0.0;
    for (double x : {0.0, f.width - 1.0})
      for (double y : {0.0, f.height - 1.0})
      {
        const Eigen::Vector2d d(x, y);
        corner = std::max(corner, (*f.camera.distortion().undistort(d) - d).norm());
      }
    const Eigen::Vector3d forward = f.camera.pose().worldFromCamera().linear().col(2);
    std::printf("camera %-10s %dx%d  corners displaced %.1f px  height %.2f m  looking down %.1f deg\n", f.name.c_str(),
                f.width, f.height, corner, f.camera.pose().center().z(), std::asin(-forward.z()) * 180.0 / M_PI);
    cv::Mat bgr;
    cv::cvtColor(survey.fixedCleanImage(static_cast<int>(c)), bgr, cv::COLOR_RGB2BGR);
    cv::imwrite(dir + "/" + f.name + ".png", bgr);
  }
}

// --time T1,T2,... (default 0, 10, 20, 30 s).
std::vector<double> surveyTimes(const ic::CommandLine& cli)
{
  if (!cli.has("time"))
    return {0, 10, 20, 30};
  std::vector<double> times;
  const std::string list = cli.value("time");
  for (size_t start = 0; start <= list.size();)
  {
    const size_t comma = std::min(list.find(',', start), list.size());
    times.push_back(std::atof(list.substr(start, comma - start).c_str()));
    start = comma + 1;
  }
  return times;
}

// The Xtion's RGB and false-colour depth at survey time t.
void renderXtionView(const sim::SurveySimulator& survey, double t, const std::string& dir)
{
  const sim::World& w = survey.world();
  const int64_t stamp = static_cast<int64_t>(t * 1e9);
  const sim::ViewCamera cam = survey.xtionCamera(stamp);
  sim::RenderOptions ro;
  ro.supersampling = w.xtion.supersampling;
  const sim::RenderedView view = survey.renderer().render(cam, ro);
  const cv::Mat depth = sim::simulateXtionDepth(view, w, cam, w.xtion.depth, true, 1, w.appearance.depth);
  char name[64];
  std::snprintf(name, sizeof(name), "xtion_%05.1f", t);
  cv::Mat bgr;
  cv::cvtColor(sim::applyCameraOptics(view.rgb, w.appearance.xtion_rgb, cam), bgr, cv::COLOR_RGB2BGR);
  cv::imwrite(dir + "/" + name + ".png", bgr);
  cv::Mat d8, colour;
  depth.convertTo(d8, CV_8U, 255.0 / 5000.0);
  cv::applyColorMap(d8, colour, cv::COLORMAP_JET);
  colour.setTo(cv::Scalar(0, 0, 0), depth == 0);
  cv::imwrite(dir + "/" + name + "_depth.png", colour);
}
}  // namespace

int main(int argc, char** argv)
{
  ic::CommandLine cli(argc, argv, {"world", "out-dir", "time", "seed"}, {});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  sim::SimulationOptions options;
  options.seed = static_cast<uint64_t>(cli.number("seed", 0));
  options.duration_s = 1e4;
  if (!cli.error().empty() || !cli.has("world") || !cli.has("out-dir"))
  {
    std::cerr << "render_world: " << (cli.error().empty() ? "--world and --out-dir are required" : cli.error())
              << "\n\n"
              << kUsage;
    return 2;
  }
  auto world = sim::loadWorldFile(cli.value("world"));
  if (!world)
  {
    std::cerr << "render_world: " << world.error().describe() << "\n";
    return 2;
  }
  auto survey = sim::SurveySimulator::create(std::move(*world), options);
  if (!survey)
  {
    std::cerr << "render_world: " << survey.error().describe() << "\n";
    return 2;
  }
  const std::string dir = cli.value("out-dir");
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec)
  {
    std::cerr << "render_world: cannot create " << dir << ": " << ec.message() << "\n";
    return 2;
  }
  std::printf("world %s: %zu surfaces, route lap %.1f s\n", survey->world().name.c_str(),
              survey->world().surfaces.size(), survey->trajectory().lapDuration());
  renderFixedCameras(*survey, dir);
  for (const double t : surveyTimes(cli))
    renderXtionView(*survey, t, dir);
  return 0;
}
