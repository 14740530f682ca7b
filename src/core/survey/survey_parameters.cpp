#include "insitu_calibration/survey/survey_parameters.h"

namespace insitu_calibration
{
namespace
{
using Range = ParameterRange;

// The keyframes, the map lines used and the localiser behind tf (the map adjustment).
void readMapParameters(ParameterSource& read, SurveyOptions& options)
{
  options.fixed_image_period_s =
      read.number("fixed_image_period", options.fixed_image_period_s, Range::closed(0.0, 3600.0, "s"));
  options.min_map_support = read.integer("min_map_support", options.min_map_support, Range::integers(1, 1000));
  options.max_map_spread_m = read.number("max_map_spread", options.max_map_spread_m, Range::positive(10.0, "m"));
  // Fusion of the observations too uncertain for the map on their own (LineMapOptions::max_fusion_sigma_m).
  LineMapOptions& map = options.map;
  map.max_fusion_sigma_m = read.number("map/max_fusion_sigma", map.max_fusion_sigma_m, Range::closed(0.0, 1.0, "m"));
  map.min_fusion_keyframes =
      read.integer("map/min_fusion_keyframes", map.min_fusion_keyframes, Range::integers(1, 1000));
  map.fusion_floor_m = read.number("map/fusion_floor", map.fusion_floor_m, Range::closed(0.0, 1.0, "m"));
  // Small depth steps pooled over a map line's observations (LineMapOptions::depth_step_sigmas).
  map.depth_step_sigmas = read.number("map/depth_step_sigmas", map.depth_step_sigmas, Range::closed(0.0, 100.0));
  map.depth_step_min_m = read.number("map/depth_step_min", map.depth_step_min_m, Range::closed(0.0, 1.0, "m"));
  options.keyframes.min_translation_m =
      read.number("keyframe/min_translation", options.keyframes.min_translation_m, Range::closed(0.0, 100.0, "m"));
  options.keyframes.min_rotation_deg =
      read.number("keyframe/min_rotation_deg", options.keyframes.min_rotation_deg, Range::closed(0.0, 180.0, "deg"));
  options.localization_sigma_m =
      read.number("localization_sigma_m", options.localization_sigma_m, Range::closed(0.0, 10.0, "m"));
  options.localization_sigma_deg =
      read.number("localization_sigma_deg", options.localization_sigma_deg, Range::closed(0.0, 90.0, "deg"));
  options.localization_correlation_s =
      read.number("localization_correlation_s", options.localization_correlation_s, Range::positive(86400.0, "s"));
  LineMapAdjustmentOptions& a = options.adjustment;  // odometry between consecutive keyframes (0 m: not used)
  a.odometry_sigma_m = read.number("odometry/sigma_m", a.odometry_sigma_m, Range::closed(0.0, 10.0, "m"));
  a.odometry_sigma_per_m = read.number("odometry/sigma_per_m", a.odometry_sigma_per_m, Range::closed(0.0, 10.0));
  a.odometry_sigma_deg = read.number("odometry/sigma_deg", a.odometry_sigma_deg, Range::closed(0.0, 180.0, "deg"));
  a.odometry_sigma_per_deg = read.number("odometry/sigma_per_deg", a.odometry_sigma_per_deg, Range::closed(0.0, 10.0));
  a.iterative_above_keyframes =
      static_cast<size_t>(read.integer("map_adjustment/iterative_above_keyframes",
                                       static_cast<int>(a.iterative_above_keyframes), Range::integers(0, 1000000)));
  // The depth sampler's jump widened on slanted surfaces (DepthSamplerOptions::slant_allowance).
  options.rgbd.sampler.slant_allowance = read.flag("depth/slant_allowance", options.rgbd.sampler.slant_allowance);
  // The Xtion's depth-to-RGB misregistration (DepthSamplerOptions::registration_offset_px).
  Eigen::Vector2d& registration = options.rgbd.sampler.registration_offset_px;
  registration.x() = read.number("depth_registration/x_px", registration.x(), Range::closed(-10.0, 10.0, "px"));
  registration.y() = read.number("depth_registration/y_px", registration.y(), Range::closed(-10.0, 10.0, "px"));
  double& registration_sigma = options.rgbd.sampler.registration_sigma_px;
  registration_sigma = read.number("depth_registration/sigma_px", registration_sigma, Range::closed(0.0, 10.0, "px"));
  options.shared_map_line_sigma = read.flag("depth_registration/in_map_line_sigma", options.shared_map_line_sigma);
  options.shared_map_errors_in_sigma = read.flag("uncertainty/shared_map_errors", options.shared_map_errors_in_sigma);
}

// Lines on the floor beyond the depth range (map/floor_lines.h).
void readFloorParameters(ParameterSource& read, FloorLineOptions& floor)
{
  floor.enabled = read.flag("floor_lines", floor.enabled);
  floor.depth_confirmation = floor.extend_confirmed = read.flag("floor/extended", floor.depth_confirmation);
  floor.floor_height_m = read.number("floor/height", floor.floor_height_m, Range::closed(-100.0, 100.0, "m"));
  floor.max_range_m = read.number("floor/max_range", floor.max_range_m, Range::positive(100.0, "m"));
  floor.tilt_sigma_deg = read.number("floor/tilt_sigma_deg", floor.tilt_sigma_deg, Range::closed(0.0, 10.0, "deg"));
  floor.height_sigma_m = read.number("floor/height_sigma", floor.height_sigma_m, Range::closed(0.0, 1.0, "m"));
}

// Lines on the ceiling that depth measured (map/ceiling_lines.h).
void readCeilingParameters(ParameterSource& read, CeilingLineOptions& ceiling)
{
  ceiling.enabled = read.flag("ceiling_lines", ceiling.enabled);
  ceiling.min_plane_lines = static_cast<int>(
      read.number("ceiling/min_plane_lines", ceiling.min_plane_lines, Range::closed(3.0, 100000.0, "lines")));
  ceiling.min_height_m = read.number("ceiling/min_height", ceiling.min_height_m, Range::closed(0.0, 100.0, "m"));
}

// The retry of a refused camera on the map with its extensions (SurveyOptions::extended_retry).
void readExtendedRetryParameters(ParameterSource& read, SurveyOptions::ExtendedMapRetry& retry)
{
  retry.enabled = read.flag("extended_retry", retry.enabled);
  retry.max_fusion_sigma_m =
      read.number("extended_map/max_fusion_sigma", retry.max_fusion_sigma_m, Range::closed(0.0, 1.0, "m"));
  retry.ceiling_lines = read.flag("extended_map/ceiling_lines", retry.ceiling_lines);
}

// Lines triangulated from the Xtion's RGB segments (map/triangulated_lines.h).
void readTriangulationParameters(ParameterSource& read, TriangulatedLineOptions& t)
{
  t.enabled = read.flag("triangulated_lines", t.enabled);
  t.max_range_m = read.number("triangulated/max_range", t.max_range_m, Range::positive(100.0, "m"));
  t.max_sigma_m = read.number("triangulated/max_sigma", t.max_sigma_m, Range::positive(1.0, "m"));
  t.repetition_px = read.number("triangulated/repetition_px", t.repetition_px, Range::closed(0.0, 100.0, "px"));
}

// The distortions the hypotheses try (LineMatcherOptions::hypothesis_corner_px): none, then `steps` barrel
// distortions evenly up to max_corner_px at the image corner.
void readHypothesisDistortions(ParameterSource& read, LineMatcherOptions& matcher)
{
  const double largest = matcher.hypothesis_corner_px.empty() ? 0.0 : -matcher.hypothesis_corner_px.back();
  const int given_steps = static_cast<int>(matcher.hypothesis_corner_px.size()) - 1;
  const double max_corner_px =
      read.number("hypothesis_distortion/max_corner_px", largest, Range::closed(0.0, 500.0, "px"));
  const int steps = read.integer("hypothesis_distortion/steps", given_steps, Range::integers(0, 10));
  matcher.hypothesis_corner_px = {0.0};
  for (int k = 1; k <= steps && max_corner_px > 0.0; ++k)
    matcher.hypothesis_corner_px.push_back(-max_corner_px * k / steps);
  matcher.hypothesis_distortion_starts =
      read.integer("hypothesis_distortion/starts", matcher.hypothesis_distortion_starts, Range::integers(0, 64));
}

// A fixed camera's calibration options set once at start-up (its median image, the prior search, the robust
// estimation's switches); its thresholds are the table's (readFieldThresholds).
void readCameraParameters(ParameterSource& read, FixedCameraOptions& camera)
{
  camera.median_images = static_cast<size_t>(
      read.integer("median_images", static_cast<int>(camera.median_images), Range::integers(1, 255)));
  camera.matcher.search_starts = read.integer("search_starts", camera.matcher.search_starts, Range::integers(1, 64));
  camera.matcher.hypothesis_starts =
      read.integer("hypothesis_starts", camera.matcher.hypothesis_starts, Range::integers(0, 64));
  camera.matcher.hypothesis_centres =
      read.integer("hypothesis_centres", camera.matcher.hypothesis_centres, Range::integers(1, 200));
  readHypothesisDistortions(read, camera.matcher);
  camera.matcher.local_search_starts =
      read.integer("local_search_starts", camera.matcher.local_search_starts, Range::integers(1, 32));
  camera.matcher.prior_start = read.flag("prior_start", camera.matcher.prior_start);
  // Unmatched images of edges of known directions in the final calibration (LineMatcherOptions::
  // min_direction_line_px, 0: none; horizontal_direction_lines).
  camera.matcher.min_direction_line_px = read.number("direction_lines/min_length", camera.matcher.min_direction_line_px,
                                                     Range::closed(0.0, 10000.0, "px"));
  camera.matcher.horizontal_direction_lines =
      read.flag("direction_lines/horizontal", camera.matcher.horizontal_direction_lines);
  CalibrationOptions& calibration = camera.matcher.calibration;
  calibration.refinement.direction_line_noise_ratio = read.number(
      "direction_lines/noise_ratio", calibration.refinement.direction_line_noise_ratio, Range::closed(0.0, 100.0, ""));
  calibration.refinement.direction_line_sigma_px = read.number(
      "direction_lines/sigma_px", calibration.refinement.direction_line_sigma_px, Range::closed(0.0, 100.0, "px"));
  calibration.refine = read.flag("refine", calibration.refine);
  calibration.ransac = read.flag("ransac", calibration.ransac);
  camera.image_lines.refiner.thin_lines = read.flag("thin_lines", camera.image_lines.refiner.thin_lines);
  camera.thin_line_sigma_m = read.number("thin_line_sigma", camera.thin_line_sigma_m, Range::closed(0.0, 0.1, "m"));
  camera.explanation.leave_out_plain_floor = read.flag("plain_floor_test", camera.explanation.leave_out_plain_floor);
  camera.explanation.plain_floor_by_sample = read.flag("plain_floor_samples", camera.explanation.plain_floor_by_sample);
  camera.explanation.plain_ceiling = read.flag("plain_ceiling_samples", camera.explanation.plain_ceiling);
  camera.explanation.texture.min_neighbours = static_cast<size_t>(read.integer(
      "texture_min_neighbours", static_cast<int>(camera.explanation.texture.min_neighbours), Range::integers(0, 100)));
  camera.explanation.min_gradient =
      read.number("overlay_min_gradient", camera.explanation.min_gradient, Range::closed(0.1, 255.0));
  camera.explanation.faint_edge_gradient =
      read.number("faint_edge_gradient", camera.explanation.faint_edge_gradient, Range::closed(0.0, 255.0));
  camera.matcher.calibration.refinement.single_focal =
      read.flag("square_pixels", camera.matcher.calibration.refinement.single_focal);
  camera.explanation.chance_mapped_radius_px =
      read.number("chance_mapped_radius", camera.explanation.chance_mapped_radius_px, Range::closed(0.0, 10.0));
  camera.explanation.chance_needs_both_sides =
      read.flag("chance_both_sides", camera.explanation.chance_needs_both_sides);
  camera.unresolved_joints.enabled = read.flag("unresolved_joints", camera.unresolved_joints.enabled);
  camera.ambiguity.neighbourhood_share =
      read.number("ambiguity/neighbourhood_share", camera.ambiguity.neighbourhood_share, Range::closed(0.0, 0.5));
  camera.ambiguity.better_score_margin =
      read.number("ambiguity/better_score_margin", camera.ambiguity.better_score_margin, Range::closed(0.0, 100.0));
}
}  // namespace

SurveyOptions readSurveyParameters(ParameterSource& source, SurveyOptions options, FieldThresholds* thresholds)
{
  readMapParameters(source, options);
  readFloorParameters(source, options.floor);
  readCeilingParameters(source, options.ceiling);
  readTriangulationParameters(source, options.triangulated);
  readExtendedRetryParameters(source, options.extended_retry);
  options.occlusion.enabled = source.flag("occlusion_test", options.occlusion.enabled);
  options.occlusion.follow_adjustment =
      source.flag("occlusion_follows_adjustment", options.occlusion.follow_adjustment);
  options.occlusion.other_surface_margin_m = source.number(
      "occlusion_other_surface_margin", options.occlusion.other_surface_margin_m, Range::closed(0.0, 1.0, "m"));
  readCameraParameters(source, options.cameras);
  FieldThresholds field = thresholds ? *thresholds : FieldThresholds{};
  field.cameras = options.cameras;
  readFieldThresholds(source, field);
  options.cameras = field.cameras;
  if (thresholds)
    *thresholds = field;
  return options;
}

bool depthRegistrationGiven(const ParameterSource& source)
{
  return source.has("depth_registration/x_px") || source.has("depth_registration/y_px");
}
}  // namespace insitu_calibration
