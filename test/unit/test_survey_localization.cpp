// End to end without ROS, with a localiser that errs: the default world surveyed while the pose tf gives (map ->
// base_link) wanders by 2 cm / 0.5 degrees (correlation 5 s) around the truth and odometry follows the true motion,
// as simulate_survey --localization-error 0.02,0.5 records it. The map is adjusted with the keyframe poses
// (Survey's default localiser sigmas) and every fixed camera calibrated. Asserts against the truth: the cameras'
// poses relative to each other (the map is internally consistent whatever the localiser does), the absolute pose
// within the localiser's limit (its error averaged over the keyframes) plus the camera's own error, the intrinsics,
// and that each error is within 3 reported sigmas (which include the map's placement). Before the adjustment
// (tf taken as exact) the relative poses were 0.6-0.8 m and 2.5-5 degrees off on seed 2. The seed is one not used
// while tuning (2 was).
#include <gtest/gtest.h>

#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/metrics.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/survey/camera_config.h"
#include "insitu_calibration/survey/survey.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const std::string kSource = INSITU_SOURCE_DIR;
constexpr uint64_t kSeed = 13;

// Camera b's centre in camera a's frame and the rotation from b to a.
std::pair<Eigen::Vector3d, Eigen::Matrix3d> relativePose(const ic::CameraPose& a, const ic::CameraPose& b)
{
  return {a.rotation * (b.center() - a.center()), a.rotation * b.rotation.transpose()};
}

// The waiting room surveyed for duration_s by a robot whose localiser errs by 2 cm / 0.5 deg (seed kSeed).
ic::Expected<sim::SurveySimulator> localizedSimulator(double duration_s)
{
  auto world = sim::loadWorldFile(kSource + "/config/worlds/waiting_room.yaml");
  if (!world)
    return world.error();
  sim::SimulationOptions options;
  options.seed = kSeed;
  options.duration_s = duration_s;
  options.localization_sigma_m = 0.02;
  options.localization_sigma_deg = 0.5;
  return sim::SurveySimulator::create(*world, options);
}

// config/cameras.yaml's cameras (none, with a test failure, when it cannot be read).
std::vector<ic::FixedCameraConfig> defaultCameras()
{
  const auto configs = ic::loadCameraConfig(kSource + "/config/cameras.yaml");
  EXPECT_TRUE(configs) << configs.error().describe();
  std::vector<ic::FixedCameraConfig> cameras;
  for (const auto& entry : configs ? *configs : std::vector<ic::CameraConfigEntry>{})
    cameras.push_back(entry.camera);
  return cameras;
}

// Feeds the whole survey: RGB-D frames posed as the erring localiser says, with odometry (exact: odom = map
// without drift), and the fixed cameras' images.
// odom_from_map: where the odometry frame's origin is (another recording may start it elsewhere).
void feedSurvey(const sim::SurveySimulator& simulator, ic::Survey* survey, std::vector<double>* stamps,
                std::vector<Eigen::Vector3d>* pivots,
                const Eigen::Isometry3d& odom_from_map = Eigen::Isometry3d::Identity())
{
  const Eigen::Isometry3d base_from_optical = sim::baseFromRgbOptical(simulator.world().xtion);
  for (const sim::SurveyEvent& event : simulator.events())
  {
    const double stamp = 1e-9 * static_cast<double>(event.stamp_ns);
    if (event.kind == sim::SurveyEventKind::kXtion)
    {
      const sim::XtionFrame x = simulator.xtionFrame(event.index);
      const sim::ViewCamera view = simulator.xtionCamera(x.stamp_ns);
      ic::RgbdFrame frame;
      cv::cvtColor(x.rgb, frame.rgb, cv::COLOR_RGB2BGR);
      frame.depth = x.depth_mm;
      frame.camera.width = view.width;
      frame.camera.height = view.height;
      frame.camera.intrinsics = view.intrinsics;
      frame.T_map_camera = simulator.localizedMapFromBase(x.stamp_ns) * base_from_optical;
      frame.stamp = stamp;
      const auto used = survey->addRgbdFrame(frame, odom_from_map * x.map_from_optical);
      if (used && *used)
      {
        stamps->push_back(stamp);
        pivots->push_back(frame.T_map_camera.translation());
      }
    }
    else if (event.kind == sim::SurveyEventKind::kFixed)
    {
      const sim::FixedFrame f = simulator.fixedFrame(event.camera, event.index);
      cv::Mat grey;
      cv::cvtColor(f.image, grey, cv::COLOR_RGB2GRAY);
      survey->addFixedImage(simulator.world().fixed_cameras[event.camera].name, grey, stamp);
    }
  }
}

// The keyframes' remaining pose errors about their mean after the adjustment (the map's internal consistency).
void printKeyframeSpread(const sim::SurveySimulator& simulator, const ic::Survey& survey,
                         const std::vector<double>& stamps)
{
  const auto corrections = survey.poseCorrections();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), squares = sum;
  for (size_t k = 0; k < corrections.size(); ++k)
  {
    const sim::Pose2d e = simulator.localizationError(std::llround(stamps[k] * 1e9));
    const Eigen::Vector3d after(e.x + corrections[k].x, e.y + corrections[k].y, e.yaw + corrections[k].yaw);
    sum += after;
    squares += after.cwiseAbs2();
  }
  const Eigen::Vector3d mean = sum / corrections.size();
  const Eigen::Vector3d spread = (squares / corrections.size() - mean.cwiseAbs2()).cwiseMax(0.0).cwiseSqrt();
  std::printf("keyframes after the adjustment, about their mean: x %.1f mm, y %.1f mm, yaw %.3f deg\n",
              1e3 * spread.x(), 1e3 * spread.y(), spread.z() * 180.0 / M_PI);
}

// One camera's calibration against the truth and its own sigmas. Loose bounds (seed 13 is among the worst seen:
// cam_wide 75 mm, 0.87 deg, now refused by the uncertainty check): the goals (10 mm and 0.1 degrees
// relative, 1.5 times the limit absolute) are not reached on every seed yet.
void expectCalibrationNearTruth(const std::string& name, const ic::CalibrationFile& truth,
                                const ic::CameraCalibration& found, const sim::PlacementLimit& limit)
{
  const ic::CameraErrors e = ic::compareCameras(truth.camera, found.camera);
  const ic::CameraUncertainty& u = found.uncertainty;
  const double rotation_deg = e.rotation_rad * 180.0 / M_PI;
  std::printf(
      "%s: focal %+.3f %%, rotation %.4f deg (sigma %.4f, limit %.4f), position %.2f mm (sigma %.2f, "
      "limit %.2f), lambda %.2f %%\n",
      name.c_str(), 100.0 * e.focal_relative, rotation_deg, u.rotation_deg, limit.rotation_rad * 180.0 / M_PI,
      1e3 * e.center_m, 1e3 * u.position_m, 1e3 * limit.position_m, 100.0 * e.lambda_relative);
  EXPECT_LT(std::abs(e.focal_relative), 0.005) << name;
  EXPECT_LT(e.lambda_relative, 0.10) << name;
  EXPECT_LT(e.center_m, 0.1 + 1.5 * limit.position_m) << name;
  EXPECT_LT(rotation_deg, 1.2) << name;
  ASSERT_TRUE(u.available) << name;
  EXPECT_LT(e.center_m, 3.0 * u.position_m) << name;
  EXPECT_LT(rotation_deg, 3.0 * u.rotation_deg) << name;
}

// The calibrated cameras' poses relative to each other against the truth's: within 20 mm and 0.2 deg (issue 11's goal
// at 5 cm / 1.5 deg; measured here 5.5-8.8 mm and at most 0.100 deg since the localiser's priors are a Gauss-Markov
// chain; calibrate_survey on simulate_survey's bag of this seed gave 18.8-30.3 mm before it, 3.9-14.7 mm after).
void expectRelativePosesNearTruth(const std::vector<ic::CameraPose>& found, const std::vector<ic::CameraPose>& truths)
{
  for (size_t i = 0; i < found.size(); ++i)
    for (size_t j = i + 1; j < found.size(); ++j)
    {
      const auto [p, r] = relativePose(found[i], found[j]);
      const auto [pt, rt] = relativePose(truths[i], truths[j]);
      const double position_mm = 1e3 * (p - pt).norm();
      const double rotation_deg = Eigen::AngleAxisd(r * rt.transpose()).angle() * 180.0 / M_PI;
      std::printf("relative %zu-%zu: %.2f mm, %.4f deg\n", i, j, position_mm, rotation_deg);
      EXPECT_LT(position_mm, 20.0) << i << "-" << j;
      EXPECT_LT(rotation_deg, 0.2) << i << "-" << j;
    }
}
}  // namespace

TEST(SurveyLocalization, AdjustedMapKeepsTheCamerasConsistent)
{
  auto simulator = localizedSimulator(40.0);
  ASSERT_TRUE(simulator) << simulator.error().describe();
  const std::vector<ic::FixedCameraConfig> cameras = defaultCameras();
  ASSERT_FALSE(cameras.empty());
  ic::Survey survey(cameras);
  std::vector<double> stamps;
  std::vector<Eigen::Vector3d> pivots;
  feedSurvey(*simulator, &survey, &stamps, &pivots);
  ASSERT_GT(survey.mapSegments().size(), 50u);
  const ic::SurveyStats& stats = survey.stats();
  std::printf(
      "seed %llu: %zu keyframes, %zu map lines used; adjustment %.2f s CPU, keyframes moved by %.1f mm, "
      "%.3f deg\n",
      static_cast<unsigned long long>(kSeed), stats.keyframes, survey.mapSegments().size(),
      1e-3 * stats.adjustment_cpu_ms, 1e3 * stats.mean_correction_m, stats.mean_correction_deg);
  // The adjustment's CPU time (goal: under 5 s for a 40 s survey) is printed, not asserted: speed is a benchmark's
  // figure (calibrate_survey prints it per bag), and a loaded or instrumented build (scripts/sanitize) takes longer.
  printKeyframeSpread(*simulator, survey, stamps);

  std::vector<sim::LocalizationSample> errors;
  for (const int64_t t : simulator->xtionStamps())
    errors.push_back({1e-9 * static_cast<double>(t), simulator->localizationError(t)});
  std::vector<ic::CameraPose> found, truths;
  size_t refused = 0;
  for (size_t c = 0; c < simulator->world().fixed_cameras.size(); ++c)
  {
    const std::string& name = simulator->world().fixed_cameras[c].name;
    const auto result = survey.calibrate(name, "map");
    // A camera the matched lines determine too weakly is refused with the reason (FixedCamera::check): never
    // accepted with a small sigma and a large error. At most one of the three here.
    if (!result)
    {
      std::printf("%s refused: %s\n", name.c_str(), result.error().describe().c_str());
      EXPECT_FALSE(result.error().message().empty()) << name;
      EXPECT_LE(++refused, 1u) << name << ": " << result.error().describe();
      continue;
    }
    const ic::CalibrationFile truth = simulator->groundTruth(static_cast<int>(c));
    expectCalibrationNearTruth(name, truth, result->calibration,
                               sim::placementLimit(errors, stamps, pivots, truth.camera.pose().center()));
    found.push_back(result->calibration.camera.pose());
    truths.push_back(truth.camera.pose());
  }
  expectRelativePosesNearTruth(found, truths);
}

// The node's path: the adjustment computed apart from the survey (outside its lock) and installed; the latest*()
// accessors never adjust; an adjustment from before a reset is not installed.
TEST(SurveyLocalization, AdjustmentComputedApartIsInstalledUnlessReset)
{
  auto simulator = localizedSimulator(10.0);
  ASSERT_TRUE(simulator) << simulator.error().describe();
  const std::vector<ic::FixedCameraConfig> cameras = defaultCameras();
  ASSERT_FALSE(cameras.empty());
  ic::SurveyOptions options;
  options.occlusion.follow_adjustment = true;
  ic::Survey survey(cameras, options);
  std::vector<double> stamps;
  std::vector<Eigen::Vector3d> pivots;
  feedSurvey(*simulator, &survey, &stamps, &pivots);
  ASSERT_GT(survey.keyframes().size(), 10u);

  ASSERT_TRUE(survey.adjustmentDue());
  const size_t unadjusted_lines = survey.latestLineMap().size();
  EXPECT_TRUE(survey.adjustmentDue()) << "latestLineMap() must not adjust";
  ic::MapAdjustment adjustment =
      ic::Survey::computeAdjustment(survey.keyframes(), survey.options(), survey.keyframeGeneration());
  const ic::MapAdjustment again =
      ic::Survey::computeAdjustment(survey.keyframes(), survey.options(), survey.keyframeGeneration());
  ASSERT_EQ(adjustment.corrections.size(), survey.keyframes().size());
  EXPECT_GT(adjustment.observations, 0u);
  const double cpu_ms = adjustment.cpu_ms;
  // The surfaces come with it, inserted again under the corrected poses (the keyframes' depth samples).
  ASSERT_TRUE(adjustment.surfaces);
  EXPECT_GT(adjustment.surfaces->size(), survey.surfaces()->size() / 2);
  const ic::SurfaceVoxels* corrected_surfaces = adjustment.surfaces.get();
  ASSERT_TRUE(survey.installAdjustment(std::move(adjustment)));
  EXPECT_EQ(survey.surfaces().get(), corrected_surfaces);
  EXPECT_FALSE(survey.adjustmentDue());
  EXPECT_EQ(survey.stats().adjustment_cpu_ms, cpu_ms);
  // Installed is current: the lazy accessors use it as it is (no second adjustment) and agree with latest*().
  const auto segments = survey.mapSegments();
  EXPECT_EQ(survey.stats().adjustment_cpu_ms, cpu_ms);
  const auto latest = survey.latestMapSegments();
  ASSERT_EQ(segments.size(), latest.size());
  ASSERT_FALSE(segments.empty());
  for (size_t i = 0; i < segments.size(); ++i)
    EXPECT_EQ((segments[i].a - latest[i].a).norm() + (segments[i].b - latest[i].b).norm(), 0.0) << i;
  // Deterministic: the same keyframes give the same corrections.
  const auto corrections = survey.poseCorrections();
  for (size_t k = 0; k < corrections.size(); ++k)
    EXPECT_EQ(corrections[k].x, again.corrections[k].x) << k;
  std::printf("%zu keyframes: %zu map lines as inserted, %zu adjusted; adjustment %.0f ms CPU\n",
              survey.keyframes().size(), unadjusted_lines, survey.latestLineMap().size(), cpu_ms);

  const uint64_t before_reset = survey.keyframeGeneration();
  survey.reset();
  ic::MapAdjustment stale = again;
  stale.generation = before_reset;
  EXPECT_FALSE(survey.installAdjustment(std::move(stale)));
  EXPECT_TRUE(survey.latestMapSegments().empty());
}

// A survey in two recordings (calibrate_survey with two bags): the same 6 s drive recorded twice, the second time with
// its odometry starting 3 m and 60 deg elsewhere. The second recording's first keyframe is not tied to the first
// recording's last by odometry, so both recordings' keyframes get the same corrections; tied, the two odometry
// origins' difference would bend them.
TEST(SurveyLocalization, ASecondRecordingIsNotTiedToTheFirstByOdometry)
{
  auto simulator = localizedSimulator(6.0);
  ASSERT_TRUE(simulator) << simulator.error().describe();
  const Eigen::Isometry3d elsewhere(Eigen::Translation3d(3.0, -1.0, 0.0) *
                                    Eigen::AngleAxisd(M_PI / 3.0, Eigen::Vector3d::UnitZ()));
  auto correctionsOfTwoRecordings = [&](bool start_recording) {
    ic::Survey survey(defaultCameras());
    std::vector<double> stamps;
    std::vector<Eigen::Vector3d> pivots;
    survey.startRecording();  // before anything: not a second recording
    feedSurvey(*simulator, &survey, &stamps, &pivots);
    const size_t first = survey.keyframes().size();
    if (start_recording)
      survey.startRecording();
    feedSurvey(*simulator, &survey, &stamps, &pivots, elsewhere);
    EXPECT_EQ(survey.keyframes().size(), 2 * first);  // the second recording's first frame is a keyframe again
    for (size_t k = 0; k < survey.keyframes().size(); ++k)
      EXPECT_EQ(survey.keyframes()[k].starts_recording, start_recording && k == first) << k;
    // Two recordings of the same 6 s (correlation time 5 s): not taken as independent (a localiser errs alike where
    // it passes again), so the placement is one recording's, not 1 / sqrt(2) of it.
    std::vector<double> first_stamps;
    for (size_t k = 0; k < first; ++k)
      first_stamps.push_back(survey.keyframes()[k].stamp);
    const double one = ic::meanErrorScale(first_stamps, survey.options().localization_correlation_s);
    EXPECT_GT(one, 0.8);
    EXPECT_NEAR(survey.mapPlacement().sigma_m, survey.options().localization_sigma_m * one, 1e-12);
    const auto corrections = survey.poseCorrections();
    double largest = 0.0;  // of the differences between the recordings' corrections of the same frame
    for (size_t k = 0; k < first; ++k)
      largest = std::max({largest, std::abs(corrections[k].x - corrections[first + k].x),
                          std::abs(corrections[k].y - corrections[first + k].y)});
    std::printf("%zu + %zu keyframes, %s: the recordings' corrections differ by up to %.3f mm\n", first, first,
                start_recording ? "two recordings" : "tied by odometry", 1e3 * largest);
    return largest;
  };
  EXPECT_LT(correctionsOfTwoRecordings(true), 1e-4);
  EXPECT_GT(correctionsOfTwoRecordings(false), 1e-3);  // the test can fail: tied, the odometry bends them
}

// A camera refused as weakly determined while the survey assumes a localiser error says that its sigmas include that
// error's effect on its map lines, and how to give a better localiser's error; with tf trusted (0, 0), and for other
// refusals, the refusal is unchanged.
TEST(SurveyLocalization, AWeaklyDeterminedRefusalNamesTheAssumedLocaliserError)
{
  const ic::Error weak(ic::ErrorCode::kDegenerate, std::string(ic::kWeaklyDeterminedRefusal) +
                                                       " (1 sigma: focal length 0.55 %, position 15 mm, rotation 0.60 "
                                                       "deg): mostly coplanar or parallel lines");
  ic::SurveyOptions assumed;
  assumed.localization_sigma_m = 0.02;
  assumed.localization_sigma_deg = 0.5;
  const ic::Error noted = ic::withAssumedLocaliser(weak, assumed);
  EXPECT_EQ(noted.code(), ic::ErrorCode::kDegenerate);
  EXPECT_EQ(noted.message().rfind(weak.message(), 0), 0u) << noted.message();
  EXPECT_NE(noted.message().find("localization_sigma_m 0.02, localization_sigma_deg 0.5"), std::string::npos)
      << noted.message();
  EXPECT_NE(noted.message().find("--localization-sigma 0,0"), std::string::npos) << noted.message();

  ic::SurveyOptions trusted = assumed;
  trusted.localization_sigma_m = 0.0;
  trusted.localization_sigma_deg = 0.0;
  EXPECT_EQ(ic::withAssumedLocaliser(weak, trusted).message(), weak.message());
  const ic::Error under(ic::ErrorCode::kDegenerate, "the matched lines leave the camera under-constrained (rank 10)");
  EXPECT_EQ(ic::withAssumedLocaliser(under, assumed).message(), under.message());
  const ic::Error few(ic::ErrorCode::kNotEnoughData, "only 5 lines matched (8 needed)");
  EXPECT_EQ(ic::withAssumedLocaliser(few, assumed).message(), few.message());
}
