// calibrate_lines: offline calibration of one camera from a correspondence file (3D lines and their images).
#include <optional>
#include <filesystem>
#include <iostream>

#include "command_line.h"
#include "insitu_calibration/refine/refinement.h"
#include "insitu_calibration/calibration.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/io/correspondence_file.h"
#include "insitu_calibration/survey/calibration_report.h"

namespace ic = insitu_calibration;

namespace
{
const char* kUsage = R"(Usage: calibrate_lines INPUT.yaml --output OUT.yaml [options]

Calibrates one camera (intrinsics, division-model distortion, pose in the world) from 3D-line/2D-line
correspondences by DLT-Lines, and writes a calibration YAML that camera_calibration_parsers and image_proc read.
INPUT.yaml is a correspondence file (see README, "Correspondence file").

Options:
  --output FILE           calibration YAML to write (atomically; nothing is written on failure)
  --report DIR            also write the calibration report there: DIR/<camera>_report.html with its PNG figures
                          (overlay, residuals, per-line RMS, coverage; README, "The calibration report"). <camera> is
                          the file's camera_name, else the name of --output without .yaml
  --distortion MODE       auto (default): estimate lambda when the data identify it (curved lines or points);
                          on: always estimate it; off: pin-hole model only
  --method METHOD         combined (default): lines and points stacked; lines: lines only; points: points only
  --world-frame NAME      frame_id written in camera_pose (default: map)
  --no-ransac             use every line (default: RANSAC over lines drops wrong correspondences)
  --inlier-threshold PX   RANSAC: a line is an inlier below this RMS point-to-line error (default 3; raised to 3.5 x
                          the inliers' median error when the data are noisier)
  --seed N                RANSAC's random seed (default 1)
  --no-refine             keep the linear DLT result (default: Ceres refinement of geometric errors)
  --loss NAME             refinement's robust loss: huber (default), cauchy or none
  --loss-scale PX         the robust loss's scale in pixels (default: 2.5 x the noise level the residuals show)
  --line-residual KIND    refinement's line error: joint (default; every image point to the projected 3D line, the
                          3D line fitted to its world points within their noise), image (to the line through the
                          first and last world points, taken as exact), world (every world point's projection to
                          its nearest image part) or both (image and world)
  --image-sigma PX        joint: the image points' noise (default: estimated from the polylines' scatter about their
                          straight lines; 1 px when no line has 3 image points)
  --world-sigma M         joint: the world points' noise, m per axis (default: estimated from lines of 3 or more
                          world points; 0 when none has: exact). A line's world_point_sigma in the file overrides it
  --linear-stage STAGE    auto (default): plumb-line when lambda is estimated and polylines of 3+ points exist, else
                          parts; plumb-line: lambda from the straightness of all polylines, each fitted as one line,
                          then the pin-hole DLT; parts: the paper's DLT over every part of every polyline
  --mirror-world AXIS     negate the world's x, y or z before calibrating: for a left-handed world frame (CAD tools,
                          game engines); the pose is then written in that mirrored, right-handed frame
  --single-focal          refine one focal length (fx = fy)
  --estimate-skew         refine the skew too (default: fixed at 0, as for every modern sensor)
  --paper                 the paper's plain DLT: same as --no-ransac --no-refine
  --truth FILE            a calibration YAML of the true camera: print the errors against it
  --quiet                 print only errors
  -h, --help              this text

Exit status: 0 success, 1 calibration failed (or the --report could not be written; the YAML is), 2 bad command
line or unreadable input.
)";

void printComparison(const ic::CameraModel& truth, const ic::CameraModel& estimate)
{
  const ic::CameraErrors e = ic::compareCameras(truth, estimate);
  std::printf(
      "against the truth:\n"
      "  focal error     %+.4f %%\n"
      "  rotation error  %.4f deg\n"
      "  position error  %.2f mm\n"
      "  principal pt    %.2f px\n"
      "  lambda          %.6g (truth %.6g, %.2f %% off)\n",
      100.0 * e.focal_relative, e.rotation_rad * 180.0 / M_PI, 1000.0 * e.center_m, e.principal_point_px,
      estimate.distortion().lambda, truth.distortion().lambda, 100.0 * e.lambda_relative);
}
// The command line into options; an empty string when it is valid, else what is wrong.
std::string parseOptions(ic::CommandLine& cli, ic::CalibrationOptions* options)
{
  const auto distortion = ic::parseDistortionMode(cli.value("distortion", "auto"));
  const auto method = ic::parseDltMethod(cli.value("method", "combined"));
  const auto loss = ic::parseRobustLoss(cli.value("loss", "huber"));
  const auto line_residual = ic::parseLineResidual(cli.value("line-residual", "joint"));
  const auto stage = ic::parseLinearStage(cli.value("linear-stage", "auto"));
  if (!distortion)
    return "--distortion must be auto, on or off";
  if (!method)
    return "--method must be lines, points or combined";
  if (!loss)
    return "--loss must be huber, cauchy or none";
  if (!line_residual)
    return "--line-residual must be joint, image, world or both";
  if (!stage)
    return "--linear-stage must be auto, plumb-line or parts";
  if (cli.has("mirror-world") && !ic::parseMirrorAxis(cli.value("mirror-world")))
    return "--mirror-world must be x, y or z";
  options->distortion = *distortion;
  options->method = *method;
  options->linear_stage = *stage;
  options->detect_left_handed = true;
  options->ransac = !cli.flag("no-ransac") && !cli.flag("paper");
  options->refine = !cli.flag("no-refine") && !cli.flag("paper");
  // The numbers' defaults are the option structs' own (one home for each default).
  options->ransac_options.inlier_threshold_px =
      cli.number("inlier-threshold", options->ransac_options.inlier_threshold_px);
  options->ransac_options.seed = static_cast<unsigned>(cli.number("seed", options->ransac_options.seed));
  options->refinement.loss = *loss;
  options->refinement.loss_scale_px = cli.number("loss-scale", options->refinement.loss_scale_px);
  options->refinement.single_focal = cli.flag("single-focal");
  options->refinement.estimate_skew = cli.flag("estimate-skew");
  options->refinement.line_residual = *line_residual;
  options->refinement.image_sigma_px = cli.number("image-sigma", options->refinement.image_sigma_px);
  options->refinement.world_sigma_m = cli.number("world-sigma", options->refinement.world_sigma_m);
  if (!cli.error().empty())
    return cli.error();
  if (!(options->ransac_options.inlier_threshold_px > 0) || options->refinement.loss_scale_px < 0)
    return "--inlier-threshold must be positive and --loss-scale not negative";
  if (options->refinement.image_sigma_px < 0 || (cli.has("world-sigma") && options->refinement.world_sigma_m < 0))
    return "--image-sigma and --world-sigma must not be negative";
  return "";
}

// The correspondences (mirrored when asked) and the --truth calibration; false (after saying why) when unreadable.
bool loadInputs(const ic::CommandLine& cli, std::optional<ic::CorrespondenceSet>* data,
                std::optional<ic::CalibrationFile>* truth)
{
  auto loaded = ic::loadCorrespondenceFile(cli.positional()[0]);
  if (!loaded)
  {
    std::cerr << "calibrate_lines: " << loaded.error().describe() << "\n";
    return false;
  }
  if (cli.has("mirror-world"))
    ic::mirrorWorld(&*loaded, *ic::parseMirrorAxis(cli.value("mirror-world")));
  *data = std::move(*loaded);
  if (!cli.has("truth"))
    return true;
  auto t = ic::loadCalibrationFile(cli.value("truth"));
  if (!t)
  {
    std::cerr << "calibrate_lines: --truth: " << t.error().describe() << "\n";
    return false;
  }
  *truth = std::move(*t);
  return true;
}

void printResult(const ic::CommandLine& cli, const ic::CorrespondenceSet& data, const ic::CameraCalibration& result,
                 const std::optional<ic::CalibrationFile>& truth, const std::string& output)
{
  std::cout << "camera " << (data.camera_name.empty() ? "(unnamed)" : data.camera_name) << ", " << data.image_width
            << "x" << data.image_height << "\n"
            << ic::describeCalibration(result);
  if (cli.has("mirror-world"))
    std::cout << "world frame    mirrored (" << cli.value("mirror-world") << " -> -" << cli.value("mirror-world")
              << "): the pose is in that right-handed frame\n";
  if (truth)
    printComparison(truth->camera, result.camera);
  std::cout << "written to " << output << "\n";
}

// The report of a successful calibration into --report DIR; false (after saying why) when it could not be written.
bool writeReport(const ic::CommandLine& cli, const ic::CorrespondenceSet& data, const ic::CameraCalibration& result)
{
  ic::CalibrationReport report;
  report.camera_name =
      data.camera_name.empty() ? std::filesystem::path(cli.value("output")).stem().string() : data.camera_name;
  report.image_width = data.image_width;
  report.image_height = data.image_height;
  report.source = "the correspondence file " + cli.positional()[0] + " (calibrate_lines)";
  report.verdict = "calibrate_lines applies no acceptance checks; the result is written to " + cli.value("output");
  report.calibration = result;
  report.correspondences = data;
  for (size_t i = 0; i < data.lines.size(); ++i)
  {
    const bool inlier = i < result.inlier_lines.size() && result.inlier_lines[i];
    (inlier ? report.matched_image_lines : report.unmatched_image_lines).push_back(data.lines[i].image);
    report.map_lines.push_back({data.lines[i].world.front(), data.lines[i].world.back()});  // the 3D lines
  }
  const auto files = ic::writeCalibrationReport(cli.value("report"), report);
  if (!files)
  {
    std::cerr << "calibrate_lines: " << files.error().describe() << "\n";
    return false;
  }
  if (!cli.flag("quiet"))
    std::cout << "report written to " << files->html << "\n";
  return true;
}
}  // namespace

int main(int argc, char** argv)
{
  ic::quietSolverLogging();
  ic::CommandLine cli(
      argc, argv,
      {"output", "report", "distortion", "method", "world-frame", "truth", "inlier-threshold", "seed", "loss",
       "loss-scale", "line-residual", "image-sigma", "world-sigma", "linear-stage", "mirror-world"},
      {"quiet", "no-ransac", "no-refine", "single-focal", "estimate-skew", "paper"});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  if (!cli.error().empty() || cli.positional().size() != 1 || !cli.has("output"))
  {
    std::cerr << "calibrate_lines: "
              << (!cli.error().empty()           ? cli.error()
                  : cli.positional().size() != 1 ? "expected exactly one INPUT.yaml"
                                                 : "--output OUT.yaml is required")
              << "\n\n"
              << kUsage;
    return 2;
  }
  ic::CalibrationOptions options;
  if (const std::string error = parseOptions(cli, &options); !error.empty())
  {
    std::cerr << "calibrate_lines: " << error << "\n";
    return 2;
  }
  const std::string output = cli.value("output");
  if (output.empty() || std::filesystem::is_directory(output))
  {
    std::cerr << "calibrate_lines: --output must name a file (got '" << output << "')\n";
    return 2;
  }
  std::optional<ic::CorrespondenceSet> data;
  std::optional<ic::CalibrationFile> truth;
  if (!loadInputs(cli, &data, &truth))
    return 2;
  const auto result = ic::calibrateCamera(*data, options);
  if (!result)
  {
    std::cerr << "calibrate_lines: calibration failed, nothing written: " << result.error().describe() << "\n";
    return 1;
  }
  const ic::Status saved =
      ic::saveCalibrationFile(output, ic::toCalibrationFile(*data, *result, cli.value("world-frame", "map")));
  if (!saved)
  {
    std::cerr << "calibrate_lines: " << saved.error().describe() << "\n";
    return 1;
  }
  if (!cli.flag("quiet"))
    printResult(cli, *data, *result, truth, output);
  if (cli.has("report") && !writeReport(cli, *data, *result))
    return 1;
  return 0;
}
