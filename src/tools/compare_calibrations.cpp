// compare_calibrations: a table of calibrations against the truth (the simulator's ground-truth files).
#include <filesystem>
#include <iostream>

#include "command_line.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/metrics.h"

namespace ic = insitu_calibration;
namespace fs = std::filesystem;

namespace
{
const char* kUsage = R"(Usage: compare_calibrations --truth-dir DIR --result-dir DIR [--cameras a,b,...]

For every camera with a calibration file <name>.yaml in both directories (or the listed cameras), prints its errors
against the truth as a markdown table: relative focal error, principal point, lambda, rotation and position errors,
reprojection RMS and MSE, and the one-sigma uncertainties the calibration reported (lambda's relative to the true
lambda).
Exit status: 0 when every listed camera was found, 1 when one is missing or unreadable, 2 on a bad command line.
)";
}

int main(int argc, char** argv)
{
  ic::CommandLine cli(argc, argv, {"truth-dir", "result-dir", "cameras"}, {});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  if (!cli.error().empty() || !cli.has("truth-dir") || !cli.has("result-dir"))
  {
    std::cerr << "compare_calibrations: "
              << (cli.error().empty() ? "--truth-dir and --result-dir are required" : cli.error()) << "\n\n"
              << kUsage;
    return 2;
  }
  std::vector<std::string> names;
  if (cli.has("cameras"))
  {
    std::string list = cli.value("cameras");
    size_t start = 0;
    while (start <= list.size())
    {
      const size_t comma = list.find(',', start);
      const std::string name = list.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      if (!name.empty())
        names.push_back(name);
      if (comma == std::string::npos)
        break;
      start = comma + 1;
    }
  }
  else
  {
    for (const auto& entry : fs::directory_iterator(cli.value("truth-dir")))
      if (entry.path().extension() == ".yaml" &&
          fs::exists(fs::path(cli.value("result-dir")) / entry.path().filename()))
        names.push_back(entry.path().stem().string());
    std::sort(names.begin(), names.end());
  }
  std::printf(
      "| camera | focal error | principal point | lambda error | rotation | position | RMS | MSE | "
      "sigma fx / position / rotation / lambda |\n|---|---|---|---|---|---|---|---|---|\n");
  int status = 0;
  for (const auto& name : names)
  {
    const auto truth = ic::loadCalibrationFile(cli.value("truth-dir") + "/" + name + ".yaml");
    const auto result = ic::loadCalibrationFile(cli.value("result-dir") + "/" + name + ".yaml");
    if (!truth || !result)
    {
      std::printf("| %s | missing: %s |\n", name.c_str(), (!truth ? truth.error() : result.error()).describe().c_str());
      status = 1;
      continue;
    }
    const ic::CameraErrors e = ic::compareCameras(truth->camera, result->camera);
    const auto extra = [&](const char* key) {
      return result->quality && result->quality->extra.count(key) ? result->quality->extra.at(key) : 0.0;
    };
    std::printf(
        "| %s | %+.4f %% | %.2f px | %.2f %% | %.4f deg | %.2f mm | %.3f px | %.4f px^2 | %.3f px / %.2f mm / "
        "%.4f deg / %.2f %% |\n",
        name.c_str(), 100.0 * e.focal_relative, e.principal_point_px, 100.0 * e.lambda_relative,
        e.rotation_rad * 180.0 / M_PI, 1000.0 * e.center_m, result->quality ? result->quality->rms_px : 0.0,
        extra("mse_px2"), extra("sigma_fx_px"), 1000.0 * extra("sigma_position_m"), extra("sigma_rotation_deg"),
        truth->camera.distortion().lambda != 0.0
            ? 100.0 * extra("sigma_lambda") / std::abs(truth->camera.distortion().lambda)
            : 0.0);
  }
  return status;
}
