// make_example_correspondences: a synthetic camera with distortion and its line correspondences, with the truth.
// It made config/examples/; tests and benchmarks use the same generator.
#include <iostream>

#include "command_line.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/io/correspondence_file.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

namespace ic = insitu_calibration;

namespace
{
const char* kUsage = R"(Usage: make_example_correspondences --out FILE --truth FILE [options]

Writes a correspondence file made from a random surveillance-like camera (division-model distortion) looking into a
room, and the true camera as a calibration file.

Options:
  --seed N              random seed (default 1)
  --name NAME           camera name (default lobby_cam)
  --width W --height H  image size (default 1280 x 960)
  --lines N             number of 3D lines (default 40)
  --image-points N      image points per line, >= 2; 3+ makes curved lines that identify distortion (default 5)
  --noise PX            image noise sigma in pixels (default 0.3)
  --corner-px PX        radial displacement of the image corner by the distortion (default -15, barrel)
)";
}

int main(int argc, char** argv)
{
  ic::CommandLine cli(
      argc, argv, {"out", "truth", "seed", "name", "width", "height", "lines", "image-points", "noise", "corner-px"},
      {});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  ic::SyntheticCameraOptions camera_options;
  camera_options.image_width = static_cast<int>(cli.number("width", 1280));
  camera_options.image_height = static_cast<int>(cli.number("height", 960));
  camera_options.corner_displacement_px = cli.number("corner-px", -15.0);
  ic::SyntheticLineOptions line_options;
  line_options.lines = static_cast<int>(cli.number("lines", 40));
  line_options.image_points_per_line = static_cast<int>(cli.number("image-points", 5));
  line_options.image_noise_px = cli.number("noise", 0.3);
  const auto seed = static_cast<unsigned>(cli.number("seed", 1));
  if (!cli.error().empty() || !cli.has("out") || !cli.has("truth") || !cli.positional().empty())
  {
    std::cerr << "make_example_correspondences: "
              << (cli.error().empty() ? "--out and --truth are required" : cli.error()) << "\n\n"
              << kUsage;
    return 2;
  }
  std::mt19937 rng(seed);
  const ic::CameraModel camera = ic::randomCamera(camera_options, rng);
  ic::SyntheticLines lines =
      ic::makeSyntheticLines(camera, camera_options.image_width, camera_options.image_height, line_options, rng);
  lines.data.camera_name = cli.value("name", "lobby_cam");

  ic::CalibrationFile truth;
  truth.camera_name = lines.data.camera_name;
  truth.image_width = camera_options.image_width;
  truth.image_height = camera_options.image_height;
  truth.camera = camera;
  const ic::Status a = ic::saveCorrespondenceFile(cli.value("out"), lines.data);
  const ic::Status b = ic::saveCalibrationFile(cli.value("truth"), truth);
  if (!a || !b)
  {
    std::cerr << "make_example_correspondences: " << (!a ? a.error() : b.error()).describe() << "\n";
    return 1;
  }
  std::cout << "seed " << seed << ": " << lines.data.lines.size() << " lines written to " << cli.value("out")
            << ", truth to " << cli.value("truth") << "\n";
  return 0;
}
