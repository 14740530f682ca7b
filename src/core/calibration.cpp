#include "insitu_calibration/calibration.h"

#include <cstdio>
#include <sstream>

namespace insitu_calibration
{
std::optional<DistortionMode> parseDistortionMode(const std::string& name)
{
  if (name == "auto")
    return DistortionMode::kAuto;
  if (name == "on")
    return DistortionMode::kOn;
  if (name == "off")
    return DistortionMode::kOff;
  return std::nullopt;
}

Expected<CalibrationResult> calibrateCamera(const CorrespondenceSet& data, const CalibrationOptions& options)
{
  CalibrationResult result;
  DltOptions dlt = options.dlt;
  dlt.method = options.method;
  CorrespondenceSet selected = data;
  if (options.method == DltMethod::kLines)
    selected.points.clear();
  if (options.method == DltMethod::kPoints)
    selected.lines.clear();

  switch (options.distortion)
  {
    case DistortionMode::kOff:
      dlt.estimate_distortion = false;
      result.distortion_note = "distortion off (pin-hole model)";
      break;
    case DistortionMode::kOn:
      dlt.estimate_distortion = true;
      result.distortion_note = "distortion estimated (requested)";
      break;
    case DistortionMode::kAuto:
    {
      DltOptions with_lambda = dlt;
      with_lambda.estimate_distortion = true;
      const Status identifiable = checkDltInput(selected, with_lambda);
      dlt.estimate_distortion = identifiable.ok();
      result.distortion_note =
          identifiable ? "distortion estimated (curved image lines or point correspondences identify it)"
                       : "distortion not estimated: " + identifiable.error().message();
      break;
    }
  }

  auto solved = solveDlt(selected, dlt);
  if (!solved)
    return solved.error();
  result.dlt = *solved;
  result.camera = solved->camera;
  result.distortion_estimated = solved->distortion_estimated;
  result.iterations = solved->center_iterations;
  result.converged = solved->center_converged;
  result.reprojection = reprojectionStats(result.camera, selected);
  return result;
}

CalibrationFile toCalibrationFile(const CorrespondenceSet& data, const CalibrationResult& result,
                                  const std::string& world_frame)
{
  CalibrationFile file;
  file.camera_name = data.camera_name;
  file.image_width = data.image_width;
  file.image_height = data.image_height;
  file.world_frame = world_frame;
  file.camera = result.camera;
  file.plumb_bob = fitPlumbBob(result.camera.intrinsics(), result.camera.distortion(), data.image_width,
                               data.image_height);
  CalibrationQuality q;
  q.rms_px = result.reprojection.rms_px;
  q.median_px = result.reprojection.median_px;
  q.lines = result.dlt.lines_used;
  q.points = result.dlt.points_used;
  q.constraints = result.dlt.constraints;
  q.distortion_estimated = result.distortion_estimated;
  q.extra["mse_px2"] = result.reprojection.mse_px2;
  q.extra["max_px"] = result.reprojection.max_px;
  q.extra["iterations"] = result.iterations;
  q.extra["converged"] = result.converged ? 1.0 : 0.0;
  file.quality = q;
  return file;
}

std::string describeCalibration(const CalibrationResult& r)
{
  const Intrinsics& k = r.camera.intrinsics();
  const DivisionModel& d = r.camera.distortion();
  const Eigen::Vector3d c = r.camera.pose().center();
  char buffer[1024];
  std::snprintf(buffer, sizeof(buffer),
                "focal length   fx %.2f  fy %.2f px  (skew %.3f)\n"
                "principal pt   %.2f, %.2f px\n"
                "distortion     lambda %.6g 1/px^2 around %.2f, %.2f  [%s]\n"
                "position       %.4f %.4f %.4f m (optical centre in the world)\n"
                "reprojection   RMS %.3f px, median %.3f px, max %.3f px, MSE %.4f px^2 over %zu residuals\n"
                "data           %zu lines, %zu points, %zu constraints; %d principal-point iteration(s)%s\n",
                k.fx, k.fy, k.skew, k.cx, k.cy, d.lambda, d.center.x(), d.center.y(), r.distortion_note.c_str(),
                c.x(), c.y(), c.z(), r.reprojection.rms_px, r.reprojection.median_px, r.reprojection.max_px,
                r.reprojection.mse_px2, r.reprojection.count, r.dlt.lines_used, r.dlt.points_used, r.dlt.constraints,
                r.iterations, r.converged ? "" : " (NOT converged)");
  std::string out = buffer;
  if (r.reprojection.unprojectable > 0)
    out += "warning        " + std::to_string(r.reprojection.unprojectable) +
           " world points do not project into the camera (behind it or outside the distortion model)\n";
  return out;
}

}  // namespace insitu_calibration
