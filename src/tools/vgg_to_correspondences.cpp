// vgg_to_correspondences: turns each view of an Oxford VGG multi-view scene into a correspondence file and a
// ground-truth calibration file, so calibrate_lines can be checked against real data.
#include <iostream>

#include "command_line.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/io/correspondence_file.h"
#include "insitu_calibration/io/vgg_dataset.h"
#include "insitu_calibration/solvers/decomposition.h"

namespace ic = insitu_calibration;

namespace
{
const char* kUsage = R"(Usage: vgg_to_correspondences SCENE_DIR --width W --height H --out-dir DIR

Reads an Oxford VGG multi-view scene (*.P, *.lines, *l3d, *nview-lines) and writes for every view
DIR/<view>.yaml (correspondence file: each 3D segment seen in the view with its 2D segment) and
DIR/<view>_truth.yaml (calibration file of the ground-truth P, for calibrate_lines --truth).
Image sizes: Model House 768x576, Merton College I 1024x768. A scene reconstructed in a left-handed frame (Model
House) is mirrored (world z negated in the points and in P) so that a camera with a proper rotation can see it.
)";
}

int main(int argc, char** argv)
{
  ic::CommandLine cli(argc, argv, {"width", "height", "out-dir"}, {});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  const int width = static_cast<int>(cli.number("width", 0));
  const int height = static_cast<int>(cli.number("height", 0));
  if (!cli.error().empty() || cli.positional().size() != 1 || !cli.has("out-dir") || width <= 0 || height <= 0)
  {
    std::cerr << "vgg_to_correspondences: " << (cli.error().empty() ? "bad arguments" : cli.error()) << "\n\n"
              << kUsage;
    return 2;
  }
  const auto views = ic::loadVggScene(cli.positional()[0], width, height);
  if (!views)
  {
    std::cerr << "vgg_to_correspondences: " << views.error().describe() << "\n";
    return 1;
  }
  const std::string out_dir = cli.value("out-dir");
  for (const auto& view : *views)
  {
    const auto truth = ic::decomposeProjection(view.projection);
    if (!truth)
    {
      std::cerr << "vgg_to_correspondences: " << view.name << ": " << truth.error().describe() << "\n";
      return 1;
    }
    ic::CalibrationFile file;
    file.camera_name = view.name;
    file.image_width = width;
    file.image_height = height;
    file.world_frame = "world";
    file.camera =
        ic::CameraModel(truth->intrinsics, ic::DivisionModel{0.0, truth->intrinsics.principalPoint()}, truth->pose);
    const ic::Status a = ic::saveCorrespondenceFile(out_dir + "/" + view.name + ".yaml", view.data);
    const ic::Status b = ic::saveCalibrationFile(out_dir + "/" + view.name + "_truth.yaml", file);
    if (!a || !b)
    {
      std::cerr << "vgg_to_correspondences: " << (!a ? a.error() : b.error()).describe() << "\n";
      return 1;
    }
    std::cout << view.name << ": " << view.data.lines.size() << " lines"
              << (view.mirrored ? " (left-handed scene: world z negated to make it right-handed)" : "") << "\n";
  }
  return 0;
}
