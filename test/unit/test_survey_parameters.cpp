// The survey's parameters read by name (survey/survey_parameters.h) from a YAML parameter file
// (io/parameter_source.h), as calibrate_survey reads them: the option structs' defaults when unset, every value set
// taken, and every bad one reported with its name, its value and the allowed range.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "insitu_calibration/io/parameter_source.h"
#include "insitu_calibration/survey/survey_parameters.h"

namespace ic = insitu_calibration;

namespace
{
ic::YamlParameterSource parsed(const std::string& yaml)
{
  auto source = ic::YamlParameterSource::parse(yaml, "params.yaml");
  EXPECT_TRUE(source) << (source ? "" : source.error().message());
  return source ? *source : *ic::YamlParameterSource::parse("{}", "empty");
}
}  // namespace

TEST(SurveyParameters, UnsetParametersKeepTheStructsDefaults)
{
  // A camera list with no parameters beside it, as config/cameras.yaml.
  ic::YamlParameterSource source = parsed("cameras:\n  - name: a\n    image_width: 640\n");
  const ic::SurveyOptions read = ic::readSurveyParameters(source);
  const ic::SurveyOptions defaults;
  EXPECT_TRUE(source.ok()) << source.summary();
  EXPECT_EQ(read.min_map_support, defaults.min_map_support);
  EXPECT_EQ(read.max_map_spread_m, defaults.max_map_spread_m);
  EXPECT_EQ(read.keyframes.min_translation_m, defaults.keyframes.min_translation_m);
  EXPECT_EQ(read.localization_sigma_m, defaults.localization_sigma_m);
  EXPECT_EQ(read.adjustment.odometry_sigma_per_deg, defaults.adjustment.odometry_sigma_per_deg);
  EXPECT_EQ(read.rgbd.sampler.registration_offset_px, defaults.rgbd.sampler.registration_offset_px);
  EXPECT_EQ(read.floor.enabled, defaults.floor.enabled);
  EXPECT_EQ(read.floor.max_range_m, defaults.floor.max_range_m);
  EXPECT_EQ(read.floor.depth_confirmation, defaults.floor.depth_confirmation);
  EXPECT_EQ(read.cameras.max_rms_px, defaults.cameras.max_rms_px);
  EXPECT_EQ(read.cameras.matcher.search_starts, defaults.cameras.matcher.search_starts);
  EXPECT_EQ(read.cameras.matcher.local_search_starts, defaults.cameras.matcher.local_search_starts);
  EXPECT_EQ(read.cameras.matcher.calibration.ransac_options.inlier_threshold_px,
            defaults.cameras.matcher.calibration.ransac_options.inlier_threshold_px);
  EXPECT_EQ(read.cameras.matcher.calibration.refine, defaults.cameras.matcher.calibration.refine);
  EXPECT_EQ(read.cameras.image_lines.refiner.thin_lines, defaults.cameras.image_lines.refiner.thin_lines);
  EXPECT_FALSE(read.cameras.image_lines.refiner.thin_lines);  // off by default (docs/measurements.md, "Thin lines")
  EXPECT_TRUE(read.cameras.explanation.leave_out_plain_floor);
  EXPECT_TRUE(read.cameras.unresolved_joints.enabled);
  EXPECT_TRUE(read.cameras.matcher.prior_start);
  EXPECT_TRUE(read.cameras.explanation.plain_floor_by_sample);
  EXPECT_EQ(read.cameras.explanation.texture.min_neighbours, 0u);  // off (docs/measurements.md)
  EXPECT_EQ(read.cameras.explanation.min_gradient, 4.0);
  EXPECT_TRUE(read.cameras.explanation.plain_ceiling);
  EXPECT_EQ(read.cameras.ambiguity.neighbourhood_share, 0.05);
  EXPECT_EQ(read.cameras.ambiguity.better_score_margin, 0.5);
  EXPECT_EQ(read.cameras.explanation.faint_edge_gradient, 1.0);
  EXPECT_EQ(read.cameras.explanation.chance_mapped_radius_px, 3.0);
  EXPECT_TRUE(read.cameras.explanation.chance_needs_both_sides);
  EXPECT_TRUE(read.cameras.matcher.calibration.refinement.single_focal);
  EXPECT_EQ(read.occlusion.other_surface_margin_m, 0.1);
  EXPECT_EQ(read.ceiling.min_height_m, 2.2);
  EXPECT_TRUE(read.extended_retry.enabled);
  EXPECT_EQ(read.cameras.matcher.calibration.refinement.direction_line_noise_ratio,
            defaults.cameras.matcher.calibration.refinement.direction_line_noise_ratio);
  EXPECT_EQ(read.extended_retry.max_fusion_sigma_m, 0.012);
  EXPECT_TRUE(read.extended_retry.ceiling_lines);
}

TEST(SurveyParameters, EverySetParameterIsTaken)
{
  ic::YamlParameterSource source = parsed(R"(
fixed_image_period: 2
min_map_support: 3
max_map_spread: 0.02
keyframe: {min_translation: 0.25, min_rotation_deg: 7}
localization_sigma_m: 0.05
localization_sigma_deg: 1.5
localization_correlation_s: 8
odometry: {sigma_m: 0.001, sigma_per_m: 0.02, sigma_deg: 0.1, sigma_per_deg: 0.03}
depth_registration: {x_px: 0.7, y_px: -0.25}
floor_lines: true
floor: {height: 0.05, max_range: 8, tilt_sigma_deg: 0.1, height_sigma: 0.01, extended: true}
ceiling: {min_height: 2.5}
occlusion_other_surface_margin: 0
cameras: []
)");
  const ic::SurveyOptions o = ic::readSurveyParameters(source);
  ASSERT_TRUE(source.ok()) << source.summary();
  EXPECT_EQ(o.fixed_image_period_s, 2.0);
  EXPECT_EQ(o.min_map_support, 3);
  EXPECT_EQ(o.max_map_spread_m, 0.02);
  EXPECT_EQ(o.keyframes.min_translation_m, 0.25);
  EXPECT_EQ(o.keyframes.min_rotation_deg, 7.0);
  EXPECT_EQ(o.localization_sigma_m, 0.05);
  EXPECT_EQ(o.localization_sigma_deg, 1.5);
  EXPECT_EQ(o.localization_correlation_s, 8.0);
  EXPECT_EQ(o.adjustment.odometry_sigma_m, 0.001);
  EXPECT_EQ(o.adjustment.odometry_sigma_per_m, 0.02);
  EXPECT_EQ(o.adjustment.odometry_sigma_deg, 0.1);
  EXPECT_EQ(o.adjustment.odometry_sigma_per_deg, 0.03);
  EXPECT_EQ(o.rgbd.sampler.registration_offset_px, Eigen::Vector2d(0.7, -0.25));
  EXPECT_TRUE(o.floor.enabled);
  EXPECT_EQ(o.floor.floor_height_m, 0.05);
  EXPECT_EQ(o.floor.max_range_m, 8.0);
  EXPECT_EQ(o.floor.tilt_sigma_deg, 0.1);
  EXPECT_EQ(o.floor.height_sigma_m, 0.01);
  EXPECT_TRUE(o.floor.depth_confirmation);
  EXPECT_TRUE(o.floor.extend_confirmed);
  EXPECT_EQ(o.ceiling.min_height_m, 2.5);
  EXPECT_EQ(o.occlusion.other_surface_margin_m, 0.0);
}

TEST(SurveyParameters, EverySetCameraParameterIsTaken)
{
  ic::YamlParameterSource source = parsed(R"(
median_images: 9
max_rms_px: 2.5
min_focal_ratio: 0.3
max_focal_ratio: 5
min_matched_lines: 12
search_starts: 6
hypothesis_starts: 3
hypothesis_centres: 7
hypothesis_distortion: {max_corner_px: 30, steps: 2, starts: 1}
local_search_starts: 2
prior_start: false
ransac_threshold_px: 4.5
ransac: false
refine: no
thin_lines: true
thin_line_sigma: 0.005
plain_floor_test: false
plain_floor_samples: false
plain_ceiling_samples: false
texture_min_neighbours: 6
overlay_min_gradient: 2.5
faint_edge_gradient: 0
chance_mapped_radius: 0
chance_both_sides: false
square_pixels: false
unresolved_joints: false
ambiguity: {neighbourhood_share: 0, better_score_margin: 0}
cameras: []
)");
  const ic::FixedCameraOptions o = ic::readSurveyParameters(source).cameras;
  ASSERT_TRUE(source.ok()) << source.summary();
  EXPECT_EQ(o.median_images, 9u);
  EXPECT_EQ(o.max_rms_px, 2.5);
  EXPECT_EQ(o.min_focal_ratio, 0.3);
  EXPECT_EQ(o.max_focal_ratio, 5.0);
  EXPECT_EQ(o.min_matched_lines, 12u);
  EXPECT_EQ(o.matcher.search_starts, 6);
  EXPECT_EQ(o.matcher.hypothesis_starts, 3);
  EXPECT_EQ(o.matcher.hypothesis_centres, 7);
  EXPECT_EQ(o.matcher.hypothesis_corner_px, (std::vector<double>{0.0, -15.0, -30.0}));
  EXPECT_EQ(o.matcher.hypothesis_distortion_starts, 1);
  EXPECT_EQ(o.matcher.local_search_starts, 2);
  EXPECT_EQ(o.matcher.calibration.ransac_options.inlier_threshold_px, 4.5);
  EXPECT_FALSE(o.matcher.calibration.ransac);
  EXPECT_FALSE(o.matcher.calibration.refine);
  EXPECT_TRUE(o.image_lines.refiner.thin_lines);
  EXPECT_EQ(o.thin_line_sigma_m, 0.005);
  EXPECT_FALSE(o.explanation.leave_out_plain_floor);
  EXPECT_FALSE(o.unresolved_joints.enabled);
  EXPECT_FALSE(o.matcher.prior_start);
  EXPECT_FALSE(o.explanation.plain_floor_by_sample);
  EXPECT_FALSE(o.explanation.plain_ceiling);
  EXPECT_EQ(o.explanation.texture.min_neighbours, 6u);
  EXPECT_EQ(o.explanation.min_gradient, 2.5);
  EXPECT_EQ(o.explanation.faint_edge_gradient, 0.0);
  EXPECT_EQ(o.explanation.chance_mapped_radius_px, 0.0);
  EXPECT_FALSE(o.explanation.chance_needs_both_sides);
  EXPECT_FALSE(o.matcher.calibration.refinement.single_focal);
  EXPECT_EQ(o.ambiguity.neighbourhood_share, 0.0);
  EXPECT_EQ(o.ambiguity.better_score_margin, 0.0);
}

TEST(SurveyParameters, TheExtendedRetryParametersAreTaken)
{
  ic::YamlParameterSource source = parsed(R"(
extended_retry: false
extended_map: {max_fusion_sigma: 0.02, ceiling_lines: false}
cameras: []
)");
  const ic::SurveyOptions o = ic::readSurveyParameters(source);
  ASSERT_TRUE(source.ok()) << source.summary();
  EXPECT_FALSE(o.extended_retry.enabled);  // on by default
  EXPECT_EQ(o.extended_retry.max_fusion_sigma_m, 0.02);
  EXPECT_FALSE(o.extended_retry.ceiling_lines);
}

TEST(SurveyParameters, TheDirectionLinesNoiseRatioAndSigmaAreTaken)
{
  ic::YamlParameterSource source = parsed("direction_lines: {noise_ratio: 3.5, sigma_px: 0.4}\ncameras: []\n");
  const ic::SurveyOptions o = ic::readSurveyParameters(source);
  ASSERT_TRUE(source.ok()) << source.summary();
  EXPECT_EQ(o.cameras.matcher.calibration.refinement.direction_line_noise_ratio, 3.5);
  EXPECT_EQ(o.cameras.matcher.calibration.refinement.direction_line_sigma_px, 0.4);
  EXPECT_EQ(ic::SurveyOptions().cameras.matcher.calibration.refinement.direction_line_sigma_px, 0.0);
  for (const char* text : {"direction_lines: {noise_ratio: -1}\ncameras: []\n",
                           "direction_lines: {sigma_px: -0.1}\ncameras: []\n"})
  {
    ic::YamlParameterSource bad = parsed(text);
    ic::readSurveyParameters(bad);
    EXPECT_FALSE(bad.ok()) << text;
  }
}

TEST(SurveyParameters, BadValuesAreEachReportedAndKeepTheirDefaults)
{
  ic::YamlParameterSource source = parsed(R"(
max_rms_px: fast
min_map_support: 2.5
keyframe: {min_translation: -1}
localization_sigma_m: .nan
ransac: 1
min_focal_ratio: 4
max_focal_ratio: 3
median_images: [1, 2]
depth_registration: {x_px: 12}
)");
  const ic::SurveyOptions o = ic::readSurveyParameters(source);
  const ic::SurveyOptions defaults;
  EXPECT_FALSE(source.ok());
  const std::vector<std::string> expected = {
      "params.yaml: parameter ~min_map_support is 2.5, allowed: an integer in [1, 1000]",
      "params.yaml: parameter ~keyframe/min_translation is -1, allowed: a number in [0, 100] m",
      "params.yaml: parameter ~localization_sigma_m is nan, allowed: a number in [0, 10] m",
      "params.yaml: parameter ~depth_registration/x_px is 12, allowed: a number in [-10, 10] px",
      "params.yaml: parameter ~median_images is a list of 2, allowed: an integer in [1, 255]",
      "params.yaml: parameter ~ransac is the number 1, allowed: true or false",
      "params.yaml: parameter ~max_rms_px is the string 'fast', allowed: a number in (0, 100] px",
      "parameters ~min_focal_ratio (4) and ~max_focal_ratio (3): the minimum must be below the maximum",
  };
  EXPECT_EQ(source.errors(), expected);
  EXPECT_EQ(o.cameras.max_rms_px, defaults.cameras.max_rms_px);
  EXPECT_EQ(o.min_map_support, defaults.min_map_support);
  EXPECT_EQ(o.keyframes.min_translation_m, defaults.keyframes.min_translation_m);
  EXPECT_EQ(o.localization_sigma_m, defaults.localization_sigma_m);
  EXPECT_EQ(o.cameras.median_images, defaults.cameras.median_images);
  EXPECT_EQ(o.cameras.matcher.calibration.ransac, defaults.cameras.matcher.calibration.ransac);
  EXPECT_EQ(o.rgbd.sampler.registration_offset_px, defaults.rgbd.sampler.registration_offset_px);
}

TEST(SurveyParameters, MalformedParameterFilesAreRefused)
{
  const auto not_a_map = ic::YamlParameterSource::parse("- 1\n- 2\n", "list.yaml");
  ASSERT_FALSE(not_a_map);
  EXPECT_EQ(not_a_map.error().code(), ic::ErrorCode::kParseError);
  EXPECT_NE(not_a_map.error().message().find("list.yaml: expected a map of parameters"), std::string::npos)
      << not_a_map.error().message();
  const auto broken = ic::YamlParameterSource::parse("max_rms_px: [1, 2\n", "broken.yaml");
  ASSERT_FALSE(broken);
  EXPECT_NE(broken.error().message().find("broken.yaml"), std::string::npos) << broken.error().message();
  const auto missing = ic::YamlParameterSource::load("/nonexistent/params.yaml");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message().find("/nonexistent/params.yaml"), std::string::npos) << missing.error().message();
  // An empty file sets nothing.
  ic::YamlParameterSource empty = parsed("");
  const ic::SurveyOptions o = ic::readSurveyParameters(empty);
  EXPECT_TRUE(empty.ok());
  EXPECT_EQ(o.cameras.max_rms_px, ic::SurveyOptions().cameras.max_rms_px);
}

// calibrate_survey estimates the depth registration unless the parameters give it: whether a name is set, whatever
// its value (0 included), nested or not.
TEST(SurveyParameters, TellsWhetherAParameterIsSet)
{
  ic::YamlParameterSource source = parsed("depth_registration:\n  x_px: 0\nmax_rms_px: 1.5\n");
  EXPECT_TRUE(source.has("depth_registration/x_px"));
  EXPECT_FALSE(source.has("depth_registration/y_px"));
  EXPECT_TRUE(source.has("max_rms_px"));
  EXPECT_FALSE(source.has("depth_registration"));
  EXPECT_FALSE(parsed("cameras:\n  - name: a\n").has("depth_registration/x_px"));
}

TEST(SurveyParameters, TellsWhetherTheDepthRegistrationIsGiven)
{
  EXPECT_TRUE(ic::depthRegistrationGiven(parsed("depth_registration:\n  y_px: -0.3\n")));
  EXPECT_TRUE(ic::depthRegistrationGiven(parsed("depth_registration: {x_px: 0, y_px: 0}\n")));
  // Its sigma or the estimate's switch alone do not give the offset.
  EXPECT_FALSE(ic::depthRegistrationGiven(parsed("depth_registration: {sigma_px: 0.2, estimate: true}\n")));
  EXPECT_FALSE(ic::depthRegistrationGiven(parsed("")));
}
