#include "insitu_calibration/calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "insitu_calibration/solvers/plumb_line.h"

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

std::optional<LinearStage> parseLinearStage(const std::string& name)
{
  if (name == "parts")
    return LinearStage::kParts;
  if (name == "plumb-line")
    return LinearStage::kPlumbLine;
  if (name == "auto")
    return LinearStage::kAuto;
  return std::nullopt;
}

namespace
{
bool usesPlumbLine(const CorrespondenceSet& data, const DltOptions& dlt, LinearStage stage)
{
  // kAuto starts with the DLT over parts: measured, the refinement reaches the same optimum from either stage on
  // dense polylines, and the parts stage's linear camera (with the principal-point iteration) is the better one on
  // polylines of a few good points (bench_accuracy fig2, fig2_rendered). The plumb-line stage is its fallback.
  (void)data;
  (void)dlt;
  return stage == LinearStage::kPlumbLine;
}

// The linear stage chosen, then the fallbacks when it finds no acceptable camera (an implausible lambda, a camera
// with the scene behind it): the other stage, then the pin-hole solve with lambda = 0 as the refinement's start.
Expected<DltResult> linearSolve(const CorrespondenceSet& data, const DltOptions& dlt, const CalibrationOptions& options,
                                std::string* note)
{
  const bool plumb = usesPlumbLine(data, dlt, options.linear_stage);
  *note = plumb ? "linear stage: plumb-line lambda, polylines fitted as lines" : "linear stage: DLT over parts";
  auto solved = plumb ? solvePlumbLineDlt(data, dlt) : solveDlt(data, dlt);
  // The fallbacks only start the refinement: the plain linear result (--paper) stays the paper's, refused when
  // implausible rather than a camera nobody refines.
  if (solved || !dlt.estimate_distortion || !options.lambda_fallback || !options.refine ||
      solved.error().code() != ErrorCode::kNoSolution)
    return solved;
  const std::string why = solved.error().message();
  if (!plumb)
    if (auto other = solvePlumbLineDlt(data, dlt))
    {
      *note = "linear stage: plumb-line lambda (the DLT over parts failed: " + why + ")";
      return other;
    }
  DltOptions pinhole = dlt;
  pinhole.estimate_distortion = false;
  auto fallback = plumb ? solvePlumbLineDlt(data, pinhole) : solveDlt(data, pinhole);
  if (!fallback)
    return solved;
  *note = "linear stage: pin-hole, refinement started from lambda = 0 (" + why + ")";
  fallback->distortion_estimated = true;
  return fallback;
}

// RANSAC over lines; with the plumb-line stage on the straightened lines (lambda from all polylines first, which
// wrong correspondences do not affect), pin-hole hypotheses of 6 lines.
Expected<RansacResult> selectLines(const CorrespondenceSet& data, const DltOptions& dlt,
                                   const CalibrationOptions& options, const RansacOptions& ransac_options)
{
  // kAuto: the parts stage first; when none of its hypotheses is acceptable (every lambda implausible), the
  // straightened lines.
  std::optional<Expected<RansacResult>> parts;
  if (!usesPlumbLine(data, dlt, options.linear_stage))
  {
    parts = ransacDlt(data, dlt, ransac_options);
    if (*parts || options.linear_stage == LinearStage::kParts || !options.lambda_fallback ||
        parts->error().code() != ErrorCode::kNoSolution)
      return std::move(*parts);
  }
  DivisionModel distortion{0.0, dlt.distortion_center.value_or(data.imageCenter())};
  if (dlt.estimate_distortion)
  {
    const auto estimate = estimatePlumbLineLambda(data, distortion.center);
    if (!estimate)
      return parts ? std::move(*parts) : ransacDlt(data, dlt, ransac_options);
    distortion.lambda = estimate->lambda;
  }
  DltOptions pinhole = dlt;
  pinhole.estimate_distortion = false;
  auto selected = ransacDlt(straightenCorrespondences(data, distortion), pinhole, ransac_options);
  if (selected)
    selected->camera.distortion() = distortion;
  return selected;
}

// The threshold the noise calls for: noise_threshold_factor x the median line error of the given lines.
double noiseThreshold(const CameraModel& camera, const CorrespondenceSet& data, const std::vector<bool>& use,
                      const CalibrationOptions& options)
{
  std::vector<double> errors;
  for (size_t i = 0; i < data.lines.size(); ++i)
    if (use[i])
      errors.push_back(lineError(camera, data.lines[i]));
  if (errors.empty() || !(options.noise_threshold_factor > 0.0))
    return 0.0;
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  const double median = errors[errors.size() / 2];
  return std::isfinite(median) ? options.noise_threshold_factor * median : 0.0;
}

// Per line, how much wider than the inlier threshold its own test is (at least 1). Under the joint error model the
// world points are noisy by sigma_w (the line's own or the estimated one), which the camera sees as f sigma_w / depth
// pixels on top of the image noise: the error a true line shows grows near the camera, where a threshold set by the
// typical line drops true lines (issue 13). The factor is the line's expected error over the median line's.
std::vector<double> lineThresholdFactors(const CameraModel& camera, const CorrespondenceSet& data,
                                         const CalibrationOptions& options,
                                         const std::optional<RefinementResult>& refinement)
{
  std::vector<double> factors(data.lines.size(), 1.0);
  if (!refinement || options.refinement.line_residual != LineResidual::kJoint)
    return factors;
  const double f = 0.5 * (camera.intrinsics().fx + camera.intrinsics().fy);
  const double image2 = refinement->image_sigma_px * refinement->image_sigma_px;
  std::vector<double> expected(data.lines.size(), 0.0);
  for (size_t i = 0; i < data.lines.size(); ++i)
  {
    const auto& line = data.lines[i];
    const double sigma = line.world_point_sigma_m >= 0.0 ? line.world_point_sigma_m : refinement->world_sigma_m;
    double world2 = 0.0;
    for (const auto& x : line.world)
    {
      const double depth = (camera.pose().rotation * x + camera.pose().translation).z();
      if (depth > 0.0)
        world2 += std::pow(f * sigma / depth, 2) / static_cast<double>(line.world.size());
    }
    expected[i] = std::sqrt(image2 + world2);
  }
  std::vector<double> sorted = expected;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double typical = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
  if (typical > 0.0)
    for (size_t i = 0; i < data.lines.size(); ++i)
      factors[i] = std::max(1.0, expected[i] / typical);
  return factors;
}

// The DLT with the principal-point iteration, then the refinement, on lines already selected. With an anchor (a
// camera known to be close, refined before), the refinement also starts from it and the better of the two optima
// (lower RMS) is kept; the anchor alone is used when the linear solve fails.
Status solveAndRefine(const CorrespondenceSet& inliers, const DltOptions& dlt, const CalibrationOptions& options,
                      const std::optional<CameraModel>& anchor, CameraCalibration* result)
{
  auto solved = linearSolve(inliers, dlt, options, &result->linear_note);
  if (!solved && !(anchor && options.refine))
    return solved.error();
  if (solved)
  {
    result->dlt = *solved;
    result->linear_camera = solved->camera;
    result->camera = solved->camera;
    result->iterations = solved->center_iterations;
    result->converged = solved->center_converged;
  }
  else
  {
    result->dlt = DltResult();
    result->dlt.camera = *anchor;
    result->dlt.constraints = inliers.lineConstraintCount();
    result->dlt.points_used = inliers.points.size();
    result->linear_camera = *anchor;
    result->camera = *anchor;
    result->iterations = 0;
    result->converged = true;
  }
  result->dlt.lines_used = inliers.lines.size();
  result->distortion_estimated = dlt.estimate_distortion;

  if (options.refine)
  {
    RefinementOptions refinement = options.refinement;
    refinement.estimate_distortion = result->distortion_estimated;
    std::optional<RefinementResult> best;
    std::string failure;
    std::vector<CameraModel> starts;
    if (solved)
      starts.push_back(solved->camera);
    if (anchor)
      starts.push_back(*anchor);
    for (const CameraModel& start : starts)
    {
      auto refined = refineCamera(inliers, start, refinement);
      if (!refined)
      {
        failure = refined.error().message();
        continue;
      }
      if (!best || refined->final_rms_px < best->final_rms_px - 1e-9)
        best = std::move(*refined);
    }
    if (!best)
      return Error(ErrorCode::kNoSolution, "refinement failed: " + failure);
    result->camera = best->camera;
    result->uncertainty = best->uncertainty;
    result->iterations += best->iterations;
    result->converged = result->converged && best->converged;
    result->refinement = std::move(*best);
  }
  return Success{};
}

std::optional<CameraModel> robustRefinement(const CorrespondenceSet& data, const CameraModel& initial,
                                            const CalibrationOptions& options, bool estimate_distortion)
{
  std::vector<double> errors;
  for (const auto& line : data.lines)
  {
    const double e = lineError(initial, line);
    if (std::isfinite(e))
      errors.push_back(e);
  }
  if (errors.empty())
    return std::nullopt;
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  const double final_scale = options.ransac_options.inlier_threshold_px / 3.0;
  double scale = std::max(final_scale, 2.0 * errors[errors.size() / 2]);
  RefinementOptions robust = options.refinement;
  robust.loss = RobustLoss::kCauchy;
  robust.compute_uncertainty = false;
  CameraModel camera = initial;
  for (int stage = 0; stage < 12; ++stage)
  {
    const bool last = scale <= final_scale * 1.0001;
    robust.loss_scale_px = scale;
    robust.estimate_distortion = estimate_distortion && scale <= 4.0 * final_scale;
    robust.estimate_principal_point = scale <= 4.0 * final_scale;
    const auto refined = refineCamera(data, camera, robust);
    if (!refined)
      return std::nullopt;
    camera = refined->camera;
    if (last)
      break;
    scale = std::max(final_scale, 0.4 * scale);
  }
  // A camera that ran away (focal length changed by more than half) is no anchor.
  const double ratio = camera.intrinsics().fx / initial.intrinsics().fx;
  if (!(ratio > 0.5 && ratio < 2.0))
    return std::nullopt;
  return camera;
}

// MSAC score of a camera over the lines (sum of min(e^2, t^2), e a line's RMS error) and its inliers (e < t).
double msacScore(const CameraModel& camera, const CorrespondenceSet& data, double t, std::vector<bool>* inliers)
{
  LineConsensus c = scoreLines(camera, data, t);
  *inliers = std::move(c.inliers);
  return c.score;
}
}  // namespace

void mirrorWorld(CorrespondenceSet* data, int axis)
{
  for (auto& line : data->lines)
    for (auto& x : line.world)
      x(axis) = -x(axis);
  for (auto& point : data->points)
    point.world(axis) = -point.world(axis);
}

std::optional<int> parseMirrorAxis(const std::string& name)
{
  if (name == "x")
    return 0;
  if (name == "y")
    return 1;
  if (name == "z")
    return 2;
  return std::nullopt;
}

namespace
{
Expected<CameraCalibration> calibrateInFrame(const CorrespondenceSet& data, const CalibrationOptions& options,
                                             const std::optional<CameraModel>& initial);
}

Expected<CameraCalibration> calibrateCamera(const CorrespondenceSet& data, const CalibrationOptions& options,
                                            const std::optional<CameraModel>& initial)
{
  auto result = calibrateInFrame(data, options, initial);
  if (result || !options.detect_left_handed || result.error().code() != ErrorCode::kNoSolution)
    return result;
  // A left-handed world frame (CAD tools, game engines): no proper rotation sees the scene in front, so every
  // solve fails. The same data with one axis mirrored calibrating is the proof.
  CorrespondenceSet mirrored = data;
  mirrorWorld(&mirrored, 2);
  if (!calibrateInFrame(mirrored, options, std::nullopt))
    return result;
  return Error(ErrorCode::kInvalidInput,
               "the world frame of these correspondences is left-handed: no camera sees them with a proper rotation, "
               "while with one world axis mirrored (z -> -z) they calibrate. Mirror an axis of the world points "
               "(calibrate_lines --mirror-world z); the pose is then given in that mirrored, right-handed frame");
}

namespace
{
// Whether to estimate the distortion, and why, in result->distortion_note.
void chooseDistortion(const CorrespondenceSet& selected, const CalibrationOptions& options, DltOptions* dlt,
                      CameraCalibration* result)
{
  switch (options.distortion)
  {
    case DistortionMode::kOff:
      dlt->estimate_distortion = false;
      result->distortion_note = "distortion off (pin-hole model)";
      break;
    case DistortionMode::kOn:
      dlt->estimate_distortion = true;
      result->distortion_note = "distortion estimated (requested)";
      break;
    case DistortionMode::kAuto: {
      DltOptions with_lambda = *dlt;
      with_lambda.estimate_distortion = true;
      const Status identifiable = checkDltInput(selected, with_lambda);
      dlt->estimate_distortion = identifiable.ok();
      result->distortion_note = identifiable
                                    ? "distortion estimated (curved image lines or point correspondences identify it)"
                                    : "distortion not estimated: " + identifiable.error().message();
      break;
    }
  }
}

// The first inliers (result->inlier_lines): the anchor's (the known camera refined robustly) when so many that RANSAC
// cannot do better, else RANSAC's, the lower MSAC score of the two deciding.
Status selectInitialInliers(const CorrespondenceSet& selected, const DltOptions& dlt, const CalibrationOptions& options,
                            const std::optional<CameraModel>& anchor, size_t minimal, CameraCalibration* result)
{
  if (const Status s = checkDltInput(selected, dlt); !s)
    return s.error();
  const double t = options.ransac_options.inlier_threshold_px;
  std::vector<bool> anchor_inliers;
  double anchor_score = std::numeric_limits<double>::infinity();
  if (anchor)
    anchor_score = msacScore(*anchor, selected, t, &anchor_inliers);
  const long anchor_count = std::count(anchor_inliers.begin(), anchor_inliers.end(), true);
  if (anchor && anchor_count >= static_cast<long>(minimal) &&
      anchor_count >= options.anchor_skips_ransac_fraction * static_cast<double>(selected.lines.size()))
  {
    result->inlier_lines = anchor_inliers;
    return Success{};
  }
  // With an anchor competing, RANSAC only has to find a better consensus when there is one: fewer draws.
  RansacOptions ransac_options = options.ransac_options;
  if (anchor)
    ransac_options.max_iterations = std::min(ransac_options.max_iterations, options.anchored_ransac_iterations);
  const auto ransac = selectLines(selected, dlt, options, ransac_options);
  if (!ransac)
    return ransac.error();
  result->inlier_lines = ransac->inliers;
  // Noisier data than the threshold was set for: the lines are judged again with the threshold their noise calls for,
  // so that true lines are not dropped.
  const double scaled = noiseThreshold(ransac->camera, selected, ransac->inliers, options);
  if (scaled > t)
    for (size_t i = 0; i < selected.lines.size(); ++i)
      result->inlier_lines[i] = lineError(ransac->camera, selected.lines[i]) < scaled;
  result->ransac_iterations = ransac->iterations;
  // The known camera against RANSAC's hypothesis: the lower MSAC score picks the inliers.
  std::vector<bool> ransac_inliers;
  const double ransac_score = msacScore(ransac->camera, selected, t, &ransac_inliers);
  if (anchor && anchor_score < ransac_score && anchor_count >= static_cast<long>(minimal))
    result->inlier_lines = anchor_inliers;
  return Success{};
}

// Once refined, the residuals tell the noise level: lines beyond inlier_sigmas of it are outliers too, which a loose
// RANSAC threshold let through and which would bias a weakly constrained camera. The noise level: from the
// refinement's residual variance, or robustly (the median absolute residual over the inliers' world points), which
// does not grow with the very outliers it is meant to find.
double inlierThreshold(const CameraCalibration& result, const CorrespondenceSet& inliers,
                       const CorrespondenceSet& selected, const CalibrationOptions& options)
{
  double threshold = options.ransac_options.inlier_threshold_px;
  if (options.robust_noise_level && result.refinement)
  {
    std::vector<double> residuals;
    for (const auto& line : inliers.lines)
      for (double r : lineResiduals(result.camera, line))
        if (std::isfinite(r))
          residuals.push_back(std::abs(r));
    if (!residuals.empty())
    {
      const double sigma = 1.4826 * summarize(residuals).median_px;
      threshold = std::min(threshold, std::max(options.min_inlier_threshold_px, options.inlier_sigmas * sigma));
    }
  }
  else if (result.uncertainty.available && result.uncertainty.residual_sigma_px > 0.0)
  {
    threshold = std::min(threshold, std::max(options.min_inlier_threshold_px,
                                             options.inlier_sigmas * result.uncertainty.residual_sigma_px));
  }
  return std::max(threshold, noiseThreshold(result.camera, selected, result.inlier_lines, options));
}

// A line is judged by its own error and, when the refinement ran, by its error had it been left out: a wrong line
// with enough leverage pulls the camera onto itself and only the second shows it.
std::vector<bool> judgeLines(const CameraCalibration& result, const CorrespondenceSet& selected, double threshold,
                             const CalibrationOptions& options)
{
  std::vector<bool> judged(selected.lines.size());
  std::vector<double> loo(selected.lines.size(), 0.0);
  if (result.refinement && options.leave_one_out)
  {
    size_t k = 0;
    for (size_t i = 0; i < selected.lines.size(); ++i)
      if (result.inlier_lines[i])
      {
        const double e = result.refinement->line_loo_rms_px[k++];
        loo[i] = std::isnan(e) ? 0.0 : e;
      }
  }
  const std::vector<double> factors = lineThresholdFactors(result.camera, selected, options, result.refinement);
  for (size_t i = 0; i < selected.lines.size(); ++i)
    judged[i] = lineError(result.camera, selected.lines[i]) < threshold * factors[i] && loo[i] < threshold * factors[i];
  return judged;
}

Expected<CameraCalibration> calibrateInFrame(const CorrespondenceSet& data, const CalibrationOptions& options,
                                             const std::optional<CameraModel>& initial)
{
  CameraCalibration result;
  DltOptions dlt = options.dlt;
  dlt.method = options.method;
  CorrespondenceSet selected = data;
  if (options.method == DltMethod::kLines)
    selected.points.clear();
  if (options.method == DltMethod::kPoints)
    selected.lines.clear();
  chooseDistortion(selected, options, &dlt, &result);

  // Robust selection of lines, then the DLT with the principal-point iteration on the inliers.
  result.inlier_lines.assign(selected.lines.size(), true);
  const size_t minimal = minimalLineCount(dlt);
  // The known camera, refined robustly on every line: the anchor. Graduated: a Cauchy loss whose scale starts at
  // the lines' typical error under the known camera and shrinks (x 0.4) down to a third of the inlier threshold, so
  // that the right lines pull first and the wrong ones fall out as the scale shrinks; focal length and pose only while
  // the scale is large.
  std::optional<CameraModel> anchor;
  if (initial && options.refine && !selected.lines.empty())
    anchor = robustRefinement(selected, *initial, options, dlt.estimate_distortion);
  if (options.ransac && selected.lines.size() > minimal)
    if (const Status s = selectInitialInliers(selected, dlt, options, anchor, minimal, &result); !s)
      return s.error();
  // The RANSAC hypotheses are linear and centred on the image centre; the final camera judges the lines better, so
  // the inlier set is re-evaluated with it and the solve repeated once when it changes.
  CorrespondenceSet inliers;
  for (int pass = 0; pass < 4; ++pass)
  {
    inliers = selected;
    inliers.lines.clear();
    for (size_t i = 0; i < selected.lines.size(); ++i)
      if (result.inlier_lines[i])
        inliers.lines.push_back(selected.lines[i]);
    result.inlier_count = inliers.lines.size();
    if (const Status s = solveAndRefine(inliers, dlt, options, anchor, &result); !s)
      return s.error();
    if (anchor)
      anchor = result.camera;
    if (!options.ransac)
      break;
    const double threshold = inlierThreshold(result, inliers, selected, options);
    result.inlier_threshold_px = threshold;
    const std::vector<bool> judged = judgeLines(result, selected, threshold, options);
    if (judged == result.inlier_lines || std::count(judged.begin(), judged.end(), true) < static_cast<long>(minimal))
      break;
    result.inlier_lines = judged;
  }
  result.reprojection = reprojectionStats(result.camera, inliers);
  // From wrong correspondences the refinement can carry the camera to where its own lines no longer project (behind
  // it, tens of metres away, or outside the division model's domain); the RMS would count only the points left: 0 px
  // when none are. The same majority rule as the decomposition's cheirality test.
  const ReprojectionStats& r = result.reprojection;
  if (2 * r.unprojectable > r.count + r.unprojectable)
    return Error(ErrorCode::kNoSolution, "the refined camera cannot project " + std::to_string(r.unprojectable) +
                                             " of the " + std::to_string(r.count + r.unprojectable) +
                                             " world points of its inlier lines (behind it or outside the distortion "
                                             "model's domain): wrong or degenerate correspondences");
  return result;
}
}  // namespace

CalibrationFile toCalibrationFile(const CorrespondenceSet& data, const CameraCalibration& result,
                                  const std::string& world_frame)
{
  CalibrationFile file;
  file.camera_name = data.camera_name;
  file.image_width = data.image_width;
  file.image_height = data.image_height;
  file.world_frame = world_frame;
  file.camera = result.camera;
  file.plumb_bob =
      fitPlumbBob(result.camera.intrinsics(), result.camera.distortion(), data.image_width, data.image_height);
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
  q.extra["inlier_lines"] = static_cast<double>(result.inlier_count);
  q.extra["refined"] = result.refinement ? 1.0 : 0.0;
  if (result.uncertainty.available)
  {
    const CameraUncertainty& u = result.uncertainty;
    q.extra["sigma_fx_px"] = u.fx;
    q.extra["sigma_fy_px"] = u.fy;
    q.extra["sigma_cx_px"] = u.cx;
    q.extra["sigma_cy_px"] = u.cy;
    q.extra["sigma_lambda"] = u.lambda;
    q.extra["sigma_position_m"] = u.position_m;
    q.extra["sigma_rotation_deg"] = u.rotation_deg;
  }
  file.quality = q;
  return file;
}

std::string describeCalibration(const CameraCalibration& r)
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
                k.fx, k.fy, k.skew, k.cx, k.cy, d.lambda, d.center.x(), d.center.y(), r.distortion_note.c_str(), c.x(),
                c.y(), c.z(), r.reprojection.rms_px, r.reprojection.median_px, r.reprojection.max_px,
                r.reprojection.mse_px2, r.reprojection.count, r.dlt.lines_used, r.dlt.points_used, r.dlt.constraints,
                r.iterations, r.converged ? "" : " (NOT converged)");
  std::string out = buffer;
  if (!r.linear_note.empty())
    out += "linear         " + r.linear_note.substr(r.linear_note.find(':') + 2) + "\n";
  if (r.inlier_count < r.inlier_lines.size())
  {
    std::snprintf(buffer, sizeof(buffer), " (threshold %.2f px)", r.inlier_threshold_px);
    out += "robust         " + std::to_string(r.inlier_count) + " of " + std::to_string(r.inlier_lines.size()) +
           " lines are inliers (RANSAC" + (r.inlier_threshold_px > 0.0 ? buffer : "") + "); the others were left out\n";
  }
  if (r.refinement)
  {
    const CameraUncertainty& u = r.uncertainty;
    if (u.available)
    {
      std::snprintf(buffer, sizeof(buffer),
                    "uncertainty    1 sigma: fx %.3f px, principal point %.2f, %.2f px, lambda %.3g, position %.2f mm, "
                    "rotation %.4f deg (noise %.3f px)\n",
                    u.fx, u.cx, u.cy, u.lambda, 1000.0 * u.position_m, u.rotation_deg, u.residual_sigma_px);
      out += buffer;
    }
    else
    {
      out += "uncertainty    not available: " + u.reason + "\n";
    }
    if (r.refinement->image_sigma_px > 0.0)
    {
      std::snprintf(buffer, sizeof(buffer), "noise model    image %.3f px, world %.2f mm (joint line error)\n",
                    r.refinement->image_sigma_px, 1000.0 * r.refinement->world_sigma_m);
      out += buffer;
    }
    std::snprintf(buffer, sizeof(buffer), "refinement     RMS %.3f px -> %.3f px (%s)\n", r.refinement->initial_rms_px,
                  r.refinement->final_rms_px, r.refinement->converged ? "converged" : "NOT converged");
    out += buffer;
  }
  else
  {
    out += "refinement     off (the paper's linear DLT)\n";
  }
  if (r.reprojection.unprojectable > 0)
    out += "warning        " + std::to_string(r.reprojection.unprojectable) +
           " world points do not project into the camera (behind it or outside the distortion model)\n";
  return out;
}

}  // namespace insitu_calibration
