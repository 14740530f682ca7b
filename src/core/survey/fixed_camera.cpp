#include "insitu_calibration/survey/fixed_camera.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "insitu_calibration/io/correspondence_file.h"

namespace insitu_calibration
{
namespace
{
// A measured number with four significant digits (a message's "523.4 px", not "523.423423 px").
std::string fourDigits(double value)
{
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.4g", value);
  return buffer;
}

std::string describeResult(const CameraCalibration& c, size_t matched)
{
  char buffer[512];
  const Intrinsics& k = c.camera.intrinsics();
  std::snprintf(buffer, sizeof(buffer),
                "calibrated on %zu lines (%zu inliers): fx %.1f fy %.1f px, principal point %.1f %.1f, lambda %.3g; "
                "RMS %.3f px, median %.3f px%s",
                matched, c.inlier_count, k.fx, k.fy, k.cx, k.cy, c.camera.distortion().lambda, c.reprojection.rms_px,
                c.reprojection.median_px, c.converged ? "" : " (not fully converged)");
  std::string out = buffer;
  if (c.uncertainty.available)
  {
    std::snprintf(buffer, sizeof(buffer), "; 1 sigma: fx %.2f px, position %.1f mm, rotation %.3f deg",
                  c.uncertainty.fx, 1000.0 * c.uncertainty.position_m, c.uncertainty.rotation_deg);
    out += buffer;
  }
  return out;
}

// When a weakly determined camera fails on its rotation alone and its principal point's uncertainty accounts for
// most of it (a narrow view: a shifted principal point and a turned camera move the image alike, and more of the
// same survey hardly separates them), what would: the principal point known from elsewhere. Empty otherwise.
std::string principalPointNote(const CameraUncertainty& u, const Intrinsics& k, const CameraPrior* prior,
                               const FixedCameraOptions& o)
{
  const double principal_px = std::hypot(u.cx, u.cy);
  const double as_turn_deg = std::atan2(principal_px, k.fx) * 180.0 / M_PI;
  if ((prior && prior->principal_point) || u.fx > o.max_sigma_focal_relative * k.fx ||
      u.position_m > o.max_sigma_position_m || as_turn_deg < 0.5 * u.rotation_deg)
    return "";
  char buffer[512];
  std::snprintf(buffer, sizeof(buffer),
                "; its rotation is uncertain mostly because its principal point is (%.0f px at 1 sigma, as much as a "
                "turn of %.2f deg): over this view the two move the image nearly alike. A principal point known to a "
                "few pixels (a lab calibration of this camera: principal_point and principal_point_sigma_px in its "
                "prior) separates them",
                principal_px, as_turn_deg);
  return buffer;
}

// How far the division model moves the top-left image corner, px.
double cornerDisplacement(const DivisionModel& d)
{
  const auto u = d.undistort(Eigen::Vector2d(0.0, 0.0));
  return u ? u->norm() : 0.0;
}

// The image lines of a result in the order the ambiguity test takes them (and its alternatives' matches index):
// the matched ones, then the others.
std::vector<std::vector<Eigen::Vector2d>> imageLinesOf(const FixedCameraResult& result)
{
  std::vector<std::vector<Eigen::Vector2d>> lines = result.matched_image_lines;
  lines.insert(lines.end(), result.unmatched_image_lines.begin(), result.unmatched_image_lines.end());
  return lines;
}
}  // namespace

Status FixedCameraConfig::validate() const
{
  if (name.empty())
    return Error(ErrorCode::kInvalidInput, "a camera needs a name");
  if (image_width <= 0 || image_height <= 0)
    return Error(ErrorCode::kInvalidInput, "camera '" + name + "': image_width and image_height must be positive");
  if (!prior && correspondence_file.empty())
    return Error(ErrorCode::kInvalidInput, "camera '" + name +
                                               "': give either a prior (position, direction, field of view) or a "
                                               "correspondence_file");
  if (prior && prior->principal_point &&
      !(prior->principal_point->x() >= 0.0 && prior->principal_point->x() <= image_width &&
        prior->principal_point->y() >= 0.0 && prior->principal_point->y() <= image_height))
    return Error(ErrorCode::kInvalidInput, "camera '" + name + "': the prior's principal_point lies outside the " +
                                               std::to_string(image_width) + "x" + std::to_string(image_height) +
                                               " image (px, from the top left corner)");
  return Success{};
}

std::vector<bool> imageCoverageCells(const std::vector<std::vector<Eigen::Vector2d>>& lines, int width, int height)
{
  std::vector<bool> cells(kCoverageCells * kCoverageCells, false);
  if (width <= 0 || height <= 0)
    return cells;
  for (const auto& line : lines)
    for (size_t j = 1; j < line.size(); ++j)
      for (int k = 0; k <= 8; ++k)
      {
        const Eigen::Vector2d m = line[j - 1] + (line[j] - line[j - 1]) * (k / 8.0);
        const int cx = static_cast<int>(kCoverageCells * m.x() / width);
        const int cy = static_cast<int>(kCoverageCells * m.y() / height);
        if (cx >= 0 && cx < kCoverageCells && cy >= 0 && cy < kCoverageCells)
          cells[cy * kCoverageCells + cx] = true;
      }
  return cells;
}

double imageCoverage(const std::vector<std::vector<Eigen::Vector2d>>& lines, int width, int height)
{
  const std::vector<bool> cells = imageCoverageCells(lines, width, height);
  return 100.0 * std::count(cells.begin(), cells.end(), true) / cells.size();
}

FixedCamera::FixedCamera(const FixedCameraConfig& config, const FixedCameraOptions& options)
    : config_(config), options_(options), median_(options.median_images)
{}

Status FixedCamera::addImage(const cv::Mat& image)
{
  if (image.empty())
    return Error(ErrorCode::kInvalidInput, "camera '" + config_.name + "': empty image");
  if (image.cols != config_.image_width || image.rows != config_.image_height)
    return Error(ErrorCode::kInvalidInput, "camera '" + config_.name + "': image of " + std::to_string(image.cols) +
                                               "x" + std::to_string(image.rows) + " where " +
                                               std::to_string(config_.image_width) + "x" +
                                               std::to_string(config_.image_height) + " is configured");
  return median_.add(image);
}

void FixedCamera::setOptions(const FixedCameraOptions& options)
{
  const size_t median_images = options_.median_images;
  options_ = options;
  options_.median_images = median_images;
}

void FixedCamera::reset()
{
  median_.clear();
  calibration_.reset();
  verification_reference_.reset();
  last_result_.reset();
  last_refused_.reset();
  last_matched_ = 0;
}

std::optional<CameraModel> FixedCamera::currentCamera() const
{
  if (calibration_)
    return calibration_->camera;
  if (config_.prior)
    return cameraFromPrior(*config_.prior, config_.image_width, config_.image_height);
  return std::nullopt;
}

bool FixedCamera::focalIsPlausible(const CameraModel& camera) const
{
  const Intrinsics& k = camera.intrinsics();
  const double low = options_.min_focal_ratio * config_.image_width,
               high = options_.max_focal_ratio * config_.image_width;
  return k.fx >= low && k.fx <= high && k.fy >= low && k.fy <= high;
}

LineMatcherOptions FixedCamera::matcherOptions() const
{
  LineMatcherOptions matcher = options_.matcher;
  if (config_.prior && config_.prior->principal_point)
  {
    RefinementOptions& refinement = matcher.calibration.refinement;
    refinement.principal_point_prior_center = config_.prior->principal_point;
    refinement.principal_point_prior_sigma = config_.prior->principal_point_sigma_px / config_.image_width;
  }
  return matcher;
}

Status checkDetermined(const CameraUncertainty& u, const Intrinsics& k, const CameraPrior* prior,
                       const FixedCameraOptions& options)
{
  if (!u.available)
    return Error(ErrorCode::kDegenerate, "the matched lines leave the camera under-constrained (" + u.reason +
                                             "); survey more of the camera's view");
  if (u.fx <= options.max_sigma_focal_relative * k.fx && u.position_m <= options.max_sigma_position_m &&
      u.rotation_deg <= options.max_sigma_rotation_deg)
    return Success{};
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), "1 sigma: focal length %.2f %%, position %.0f mm, rotation %.2f deg",
                100.0 * u.fx / k.fx, 1000.0 * u.position_m, u.rotation_deg);
  return Error(ErrorCode::kDegenerate, std::string(kWeaklyDeterminedRefusal) + " (" + buffer +
                                           "): mostly coplanar or parallel lines, or too small a part of the view; "
                                           "survey more of the camera's view" +
                                           principalPointNote(u, k, prior, options));
}

bool FixedCamera::isPlausible(const CameraModel& camera) const
{
  return focalIsPlausible(camera) && !(config_.prior && beyondPriorDistance(camera.pose().center(), *config_.prior,
                                                                            options_.max_prior_distance_sigmas));
}

Status FixedCamera::check(const CameraCalibration& c, size_t matched_lines, bool check_prior) const
{
  const Intrinsics& k = c.camera.intrinsics();
  const double w = config_.image_width;
  if (!focalIsPlausible(c.camera))
    return Error(ErrorCode::kNoSolution,
                 "the focal length (" + fourDigits(k.fx) + " px) is outside the plausible range " +
                     fourDigits(options_.min_focal_ratio * w) + " .. " + fourDigits(options_.max_focal_ratio * w) +
                     " px; the matches are probably wrong");
  if (c.reprojection.rms_px > options_.max_rms_px)
    return Error(ErrorCode::kNoSolution, "the reprojection error (RMS " + fourDigits(c.reprojection.rms_px) +
                                             " px) is above the limit of " + fourDigits(options_.max_rms_px) +
                                             " px; survey more of the camera's view or check its prior");
  if (matched_lines < options_.min_matched_lines)
    return Error(ErrorCode::kNotEnoughData, "only " + std::to_string(matched_lines) + " lines matched (" +
                                                std::to_string(options_.min_matched_lines) +
                                                " needed); survey more of the camera's view");
  if (config_.prior && check_prior &&
      beyondPriorDistance(c.camera.pose().center(), *config_.prior, options_.max_prior_distance_sigmas))
  {
    const double distance = (c.camera.pose().center() - config_.prior->position).norm();
    const double limit = options_.max_prior_distance_sigmas * config_.prior->position_sigma_m;
    return Error(ErrorCode::kNoSolution, "the camera came out " + fourDigits(distance) +
                                             " m from its prior position (more than " + fourDigits(limit) +
                                             " m); the matches are probably wrong, or the prior is");
  }
  if (c.refinement)
    if (const Status determined =
            checkDetermined(c.uncertainty, k, config_.prior ? &*config_.prior : nullptr, options_);
        !determined)
      return determined;
  if (!c.camera.pose().rotation.allFinite() || !c.camera.pose().translation.allFinite())
    return Error(ErrorCode::kNoSolution, "the pose is not finite");
  return Success{};
}

std::vector<double> FixedCamera::finalSigmas(const std::vector<Segment3d>& map_lines,
                                             const std::vector<double>& sigmas) const
{
  if (!config_.prior)
    return sigmas;
  const double focal = cameraFromPrior(*config_.prior, config_.image_width, config_.image_height).intrinsics().fx;
  return unresolvedJointSigmas(map_lines, sigmas, config_.prior->position, focal, options_.unresolved_joints);
}

std::vector<Segment3d> FixedCamera::unhiddenLines(const CameraModel& camera, const std::vector<Segment3d>& map_lines,
                                                  const SurfaceVoxels* occluders) const
{
  if (!occluders)
    return map_lines;
  std::vector<Segment3d> in_view;
  for (const Segment3d& line : map_lines)
    if (const auto interval = visibleInterval(camera, line, config_.image_width, config_.image_height))
      in_view.push_back({line.pointAt(interval->first), line.pointAt(interval->second)});
  return occluders->unoccludedParts(camera.pose().center(), in_view);
}

ImageExplanation FixedCamera::explain(const CameraModel& camera, const std::vector<Segment3d>& map_lines,
                                      const SurfaceVoxels* occluders, const RefinementResult* refinement,
                                      std::vector<EdgeSamples>* checked_lines,
                                      const ImageExplanationOptions* options) const
{
  return explainImage(median_.median(), camera, config_.image_width, config_.image_height,
                      unhiddenLines(camera, map_lines, occluders), refinement,
                      options ? *options : options_.explanation, checked_lines);
}

Status FixedCamera::checkExplanation(FixedCameraResult& result, const std::vector<Segment3d>& map_lines) const
{
  const CameraCalibration& c = result.calibration;
  result.explanation = explain(c.camera, map_lines, occluders_.get(), c.refinement ? &*c.refinement : nullptr,
                               &result.checked_map_lines);
  return acceptExplanation(result.explanation, options_.explanation);
}

bool FixedCamera::priorRulesOut(const CameraModel& alternative, const CameraModel& accepted) const
{
  if (!config_.prior)
    return false;
  const CameraPrior& p = *config_.prior;
  const double d_alternative = (alternative.pose().center() - p.position).norm();
  const double d_accepted = (accepted.pose().center() - p.position).norm();
  return beyondPriorDistance(alternative.pose().center(), p, options_.max_prior_distance_sigmas) &&
         d_alternative - d_accepted > options_.ambiguity.prior_margin_sigmas * p.position_sigma_m;
}

Status FixedCamera::checkAmbiguity(FixedCameraResult& result, const std::vector<Segment3d>& map_lines,
                                   const std::vector<double>& map_line_sigmas_m) const
{
  if (!options_.ambiguity.enabled)
    return Success{};
  result.ambiguity =
      findAlternativeCameras(map_lines, imageLinesOf(result), result.calibration, result.matched_map_lines,
                             config_.image_width, config_.image_height, matcherOptions(), map_line_sigmas_m,
                             finalSigmas(map_lines, map_line_sigmas_m), options_.ambiguity);
  return judgeAlternatives(result, map_lines);
}

Status FixedCamera::judgeAlternatives(FixedCameraResult& result, const std::vector<Segment3d>& map_lines) const
{
  const ViewAmbiguityOptions& o = options_.ambiguity;
  for (AlternativeCamera& alt : result.ambiguity.alternatives)
  {
    if (!alt.clearly_different)
      continue;
    if (!explainsAsWell(alt, result.ambiguity, o))
    {
      alt.dismissed = "explains less";
      continue;
    }
    // Only a check that says the alternative is wrong dismisses it (view_ambiguity.h).
    if (const Status own = check(alt.calibration, alt.matched_lines, false); dismissedByOwnChecks(own))
    {
      alt.dismissed = "its own checks refuse it: " + own.error().message().substr(0, 60);
      continue;
    }
    if (priorRulesOut(alt.calibration.camera, result.calibration.camera))
    {
      alt.dismissed = "the prior rules it out";
      continue;
    }
    const CameraCalibration& c = alt.calibration;
    // Measured as the accepted camera's was: without the map lines hidden from it.
    const ImageExplanation e = explain(c.camera, map_lines, occluders_.get(), c.refinement ? &*c.refinement : nullptr);
    if (e.samples > 0 && e.overlay_agreement < result.explanation.overlay_agreement - o.overlay_margin)
    {  // its map lines meet image edges less often: the accepted camera explains the view better
      alt.dismissed = "overlay " + std::to_string(static_cast<int>(100.0 * e.overlay_agreement)) + " %";
      continue;
    }
    return ambiguityError(result.calibration, alt, result.ambiguity);
  }
  return Success{};
}

void FixedCamera::takeBetterExplanation(FixedCameraResult& result, const std::vector<Segment3d>& map_lines,
                                        const std::string& world_frame) const
{
  const std::optional<size_t> taken = sameCameraExplainingBetter(result.ambiguity, options_.ambiguity);
  if (!taken)
    return;
  const AlternativeCamera& alt = result.ambiguity.alternatives[*taken];
  LineMatchResult matched;
  matched.matches = alt.matches;
  matched.correspondences = alt.correspondences;
  matched.calibration = alt.calibration;
  FixedCameraResult candidate = resultOfMatching(std::move(matched), imageLinesOf(result), map_lines, world_frame);
  candidate.loops = result.loops;
  candidate.ambiguity = withAcceptedAlternative(result.ambiguity, *taken, result.calibration, options_.ambiguity);
  // Every check the search's result passed, the ambiguity test against the replaced camera too; else it stays.
  if (check(candidate.calibration, candidate.matched_image_lines.size()) && checkExplanation(candidate, map_lines) &&
      judgeAlternatives(candidate, map_lines))
    result = std::move(candidate);
}

Expected<FixedCameraResult> FixedCamera::calibrateFromFile(const std::string& world_frame)
{
  auto data = loadCorrespondenceFile(config_.correspondence_file);
  if (!data)
    return data.error();
  data->camera_name = config_.name;
  if (data->image_width != config_.image_width || data->image_height != config_.image_height)
    return Error(ErrorCode::kInvalidInput,
                 config_.correspondence_file + " is for a " + std::to_string(data->image_width) + "x" +
                     std::to_string(data->image_height) + " image, the camera is " +
                     std::to_string(config_.image_width) + "x" + std::to_string(config_.image_height));
  // Square pixels are the survey's matching's assumption (square_pixels); a correspondence file's lines (CAD lines,
  // an installer's clicks) fit fx and fy apart, as calibrate_lines does.
  CalibrationOptions options = options_.matcher.calibration;
  options.refinement.single_focal = false;
  auto calibration = calibrateCamera(*data, options);
  if (!calibration)
    return calibration.error();
  FixedCameraResult result;
  result.calibration = *calibration;
  for (size_t i = 0; i < data->lines.size(); ++i)
    if (i < calibration->inlier_lines.size() && calibration->inlier_lines[i])
    {
      result.matched_image_lines.push_back(data->lines[i].image);
      result.matched_map_lines.push_back({data->lines[i].world.front(), data->lines[i].world.back()});
    }
    else
      result.unmatched_image_lines.push_back(data->lines[i].image);
  result.correspondences = *data;
  result.file = toCalibrationFile(*data, *calibration, world_frame);
  result.loops = 1;
  return result;
}

std::vector<Segment3d> FixedCamera::seeableFromPrior(const std::vector<Segment3d>& map_lines,
                                                     std::vector<double>* sigmas) const
{
  if (!occluders_ || !config_.prior)
    return map_lines;
  const CameraPrior& prior = *config_.prior;
  std::vector<Eigen::Vector3d> viewpoints = {prior.position};
  for (int axis = 0; axis < 3; ++axis)
    for (const double sign : {-1.0, 1.0})
      viewpoints.push_back(prior.position + sign * prior.position_sigma_m * Eigen::Vector3d::Unit(axis));
  std::vector<Segment3d> seeable;
  std::vector<double> seeable_sigmas;
  for (size_t i = 0; i < map_lines.size(); ++i)
    if (!occluders_->hiddenFromAll(viewpoints, map_lines[i]))
    {
      seeable.push_back(map_lines[i]);
      if (i < sigmas->size())
        seeable_sigmas.push_back((*sigmas)[i]);
    }
  if (!sigmas->empty())
    *sigmas = std::move(seeable_sigmas);
  return seeable;
}

FixedCameraResult FixedCamera::resultOfMatching(LineMatchResult matched,
                                                const std::vector<std::vector<Eigen::Vector2d>>& polylines,
                                                const std::vector<Segment3d>& map_lines,
                                                const std::string& world_frame) const
{
  FixedCameraResult result;
  result.calibration = matched.calibration;
  std::vector<bool> matched_image(polylines.size(), false);
  for (const auto& m : matched.matches)
  {
    result.matched_image_lines.push_back(polylines[m.image_line]);
    result.matched_map_lines.push_back(map_lines[m.map_line]);
    matched_image[m.image_line] = true;
  }
  for (size_t i = 0; i < polylines.size(); ++i)
    if (!matched_image[i])
      result.unmatched_image_lines.push_back(polylines[i]);
  result.correspondences = std::move(matched.correspondences);
  result.correspondences.camera_name = config_.name;
  result.file = toCalibrationFile(result.correspondences, matched.calibration, world_frame);
  return result;
}

Expected<std::vector<ImageLine>> FixedCamera::linesOfMedian(const cv::Mat& median, const DivisionModel& distortion,
                                                            bool camera_known, bool* thin_lines) const
{
  // Thin lines (joints: often a repeating grid) only once a camera is known: from the prior their repetition would
  // offer the search a match one joint over.
  ImageLineOptions line_options = options_.image_lines;
  *thin_lines = line_options.refiner.thin_lines && camera_known;
  line_options.refiner.thin_lines = *thin_lines;
  ImageLineStats stats;
  auto lines = extractImageLines(median, distortion, line_options, &stats);
  if (!lines || !lines->empty())
    return lines;
  std::string message = "no lines were found in the median image (" + stats.note + ")";
  if (!*thin_lines)
  {  // A view of joints alone (a tiled floor seen from above): thin lines are all it has.
    line_options.refiner.thin_lines = true;
    ImageLineStats thin_stats;
    auto thin = extractImageLines(median, distortion, line_options, &thin_stats);
    if (thin && !thin->empty() && options_.image_lines.refiner.thin_lines)
    {
      *thin_lines = true;
      return thin;
    }
    if (thin && !thin->empty())
      message += "; it shows " + std::to_string(thin->size()) +
                 " thin lines without a step across them (the joints of tiles, bricks or planks), which only the "
                 "parameter thin_lines uses (off by default); or calibrate this camera from CAD lines "
                 "(calibrate_lines)";
  }
  return Error(ErrorCode::kNotEnoughData, message);
}

Expected<LineMatchResult> FixedCamera::matchOnce(const std::vector<Segment3d>& map_lines,
                                                 const std::vector<std::vector<Eigen::Vector2d>>& polylines,
                                                 const std::vector<double>& map_line_sigmas_m,
                                                 const std::vector<double>& image_line_sigmas,
                                                 const std::vector<double>& final_sigmas,
                                                 const CameraModel* found) const
{
  const int w = config_.image_width, h = config_.image_height;
  // The search ranks results the final check would refuse for their distance to the prior behind the others.
  LineMatcherOptions matcher = found ? matcherOptions() : options_.matcher;
  matcher.max_prior_distance_sigmas = options_.max_prior_distance_sigmas;
  if (found)
    return matchAndCalibrateFrom(map_lines, polylines, *found, w, h, matcher, map_line_sigmas_m, image_line_sigmas,
                                 final_sigmas);
  // The prior search assumes every camera's principal point near the image centre (its results were measured so):
  // given a known principal point too, it found other cameras, worse as often as better (docs/measurements.md, "A
  // known principal point").
  CameraPrior search_prior = *config_.prior;
  search_prior.principal_point.reset();
  return matchAndCalibrate(map_lines, polylines, search_prior, w, h, matcher, map_line_sigmas_m, image_line_sigmas,
                           final_sigmas);
}

Expected<FixedCameraResult> FixedCamera::calibrateFromMap(const std::vector<Segment3d>& all_map_lines,
                                                          const std::string& world_frame,
                                                          const std::vector<double>& map_line_sigmas_all)
{
  if (median_.empty())
    return Error(ErrorCode::kNotEnoughData, kNoImageRefusal + config_.image_topic + " yet");
  if (all_map_lines.empty())
    return Error(ErrorCode::kNotEnoughData, "the 3D line map is empty: drive the robot through the camera's view");
  // Map lines no camera near the prior could see (behind surfaces the survey measured, from the prior's position
  // and from a sigma off it along each axis) would only be wrong candidates for the matching.
  std::vector<double> sigmas = map_line_sigmas_all;
  const std::vector<Segment3d> map_lines = seeableFromPrior(all_map_lines, &sigmas);
  const std::vector<double>& map_line_sigmas_m = sigmas;
  // The search weighs every map line by its own sigma; the chosen result's final calibration and its uncertainty
  // count the flanks of joints this camera does not resolve as known only to within the joint.
  const std::vector<double> final_sigmas = finalSigmas(map_lines, sigmas);
  const cv::Mat median = median_.median();
  DivisionModel distortion{0.0, imageCenter(config_.image_width, config_.image_height)};
  // A principal point the prior knows joins from the camera found on (matchOnce), so at least one more loop.
  const bool knows_principal_point = config_.prior->principal_point.has_value();
  const int loops = std::max(options_.max_loops, knows_principal_point ? 2 : 1);
  std::optional<FixedCameraResult> best;
  for (int loop = 0; loop < loops; ++loop)
  {
    bool thin_lines = false;
    const auto lines = linesOfMedian(median, distortion, best.has_value(), &thin_lines);
    if (!lines)
      return lines.error();
    std::vector<std::vector<Eigen::Vector2d>> polylines;
    std::vector<double> image_line_sigmas;
    for (const auto& l : *lines)
    {
      polylines.push_back(l.points);
      image_line_sigmas.push_back(l.thin() ? options_.thin_line_sigma_m : 0.0);
    }
    auto matched = matchOnce(map_lines, polylines, map_line_sigmas_m, image_line_sigmas, final_sigmas,
                             best ? &best->calibration.camera : nullptr);
    if (!matched)
    {
      if (best)
        break;
      return matched.error();
    }
    last_matched_ = matched->matches.size();
    FixedCameraResult result = resultOfMatching(std::move(*matched), polylines, map_lines, world_frame);
    result.loops = loop + 1;
    const DivisionModel next = result.calibration.camera.distortion();
    const double moved = std::max((next.center - distortion.center).norm(),
                                  std::abs(cornerDisplacement(next) - cornerDisplacement(distortion)));
    best = std::move(result);
    distortion = next;
    if (moved < options_.loop_tolerance_px && (thin_lines || !options_.image_lines.refiner.thin_lines) &&
        !(knows_principal_point && loop == 0))
      break;
  }
  return *best;
}

Expected<FixedCameraResult> FixedCamera::calibrate(const std::vector<Segment3d>& map_lines,
                                                   const std::string& world_frame,
                                                   const std::vector<double>& map_line_sigmas_m)
{
  if (const Status valid = config_.validate(); !valid)
    return valid.error();
  auto result = config_.correspondence_file.empty() ? calibrateFromMap(map_lines, world_frame, map_line_sigmas_m)
                                                    : calibrateFromFile(world_frame);
  if (!result)
    return result.error();
  last_refused_.reset();
  Status ok = check(result->calibration, result->matched_image_lines.size());
  if (ok && config_.correspondence_file.empty())
    ok = checkExplanation(*result, map_lines);
  if (ok && config_.correspondence_file.empty())
    ok = checkAmbiguity(*result, map_lines, map_line_sigmas_m);
  if (ok && config_.correspondence_file.empty())
    takeBetterExplanation(*result, map_lines, world_frame);
  if (!ok)
  {
    last_refused_ = *result;
    return ok.error();
  }
  result->summary = describeResult(result->calibration, result->matched_image_lines.size());
  if (config_.correspondence_file.empty())
    result->summary += "; " + result->explanation.describe() + "; " + result->ambiguity.describe();
  calibration_ = result->file;
  if (config_.correspondence_file.empty())
    measureVerificationReference(map_lines, map_line_sigmas_m);
  last_result_ = *result;
  return result;
}

Expected<std::vector<std::vector<Eigen::Vector2d>>> FixedCamera::medianLines(const DivisionModel& distortion) const
{
  const auto lines = extractImageLines(median_.median(), distortion, options_.image_lines);
  if (!lines)
    return lines.error();
  std::vector<std::vector<Eigen::Vector2d>> polylines;
  for (const auto& l : *lines)
    polylines.push_back(l.points);
  return polylines;
}

void FixedCamera::measureVerificationReference(const std::vector<Segment3d>& map_lines,
                                               const std::vector<double>& map_line_sigmas_m)
{
  verification_reference_.reset();
  const CameraModel& camera = calibration_->camera;
  const auto lines = medianLines(camera.distortion());
  if (!lines)
    return;
  CameraVerificationOptions options;
  options.search_range_deg = 0.0;  // the camera is where it was calibrated: no search
  const auto zero = verifyCameraPose(camera, config_.image_width, config_.image_height, map_lines, *lines, options,
                                     map_line_sigmas_m);
  if (!zero || zero->verdict != CameraMotionVerdict::kUnmoved)
    return;  // no sane zero: the calibration itself serves
  VerificationReference r;
  r.calibrated = camera.pose();
  r.reference.rotation = zero->rotation * camera.pose().rotation;
  r.reference.translation = zero->rotation * camera.pose().translation + zero->translation;
  verification_reference_ = r;
}

Expected<CameraMotion> FixedCamera::verify(const std::vector<Segment3d>& map_lines,
                                           const CameraVerificationOptions& options,
                                           const std::vector<double>& map_line_sigmas_m) const
{
  if (!calibration_)
    return Error(ErrorCode::kNotEnoughData, "camera " + config_.name + " is not calibrated: nothing to verify");
  if (median_.empty())
    return Error(ErrorCode::kNotEnoughData, kNoImageRefusal + config_.image_topic + " yet");
  CameraModel zero = calibration_->camera;
  const auto& r = verification_reference_;
  if (r && r->calibrated.rotation == zero.pose().rotation && r->calibrated.translation == zero.pose().translation)
    zero.pose() = r->reference;
  const auto lines = medianLines(zero.distortion());
  if (!lines)
    return lines.error();
  return verifyCameraPose(zero, config_.image_width, config_.image_height, map_lines, *lines, options,
                          map_line_sigmas_m);
}

FixedCameraStatus FixedCamera::status(const std::vector<Segment3d>& map_lines) const
{
  FixedCameraStatus s;
  s.images = median_.size();
  s.has_image = s.images > 0;
  s.map_lines = map_lines.size();
  s.calibrated = calibration_.has_value();
  s.matched_lines = last_result_ ? last_result_->matched_image_lines.size() : 0;
  if (last_result_)
    s.coverage_percent = imageCoverage(last_result_->matched_image_lines, config_.image_width, config_.image_height);
  if (const auto camera = currentCamera())
    for (const auto& l : map_lines)
      s.map_lines_visible += visibleInterval(*camera, l, config_.image_width, config_.image_height) ? 1 : 0;
  if (s.has_image && config_.correspondence_file.empty())
  {
    const auto lines =
        extractImageLines(median_.median(),
                          calibration_ ? calibration_->camera.distortion()
                                       : DivisionModel{0.0, imageCenter(config_.image_width, config_.image_height)},
                          options_.image_lines);
    s.image_lines = lines ? lines->size() : 0;
  }
  if (!config_.correspondence_file.empty())
  {
    s.ready = true;
    s.message = "calibrates from the correspondence file " + config_.correspondence_file;
  }
  else if (!s.has_image)
    s.message = "no image from " + config_.image_topic + " yet";
  else if (s.map_lines_visible < options_.min_matched_lines)
    s.message = "the line map has " + std::to_string(s.map_lines_visible) + " lines in the camera's view (" +
                std::to_string(options_.min_matched_lines) + " needed): survey its view";
  else if (s.image_lines < options_.min_matched_lines)
    s.message = "only " + std::to_string(s.image_lines) + " lines found in the camera's image";
  else
  {
    s.ready = true;
    s.message = "ready: " + std::to_string(s.map_lines_visible) + " map lines in view, " +
                std::to_string(s.image_lines) + " image lines";
  }
  return s;
}

}  // namespace insitu_calibration
