// The simulator's erring localiser (SimulationOptions::localization_*, simulate_survey --localization-error): /tf's
// map -> base_link is the true pose moved by the error, odometry stays true, the error has the stated size and
// correlation, and the placement limit is the averaged error.
#include <gtest/gtest.h>

#include <cmath>

#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/world.h"

namespace sim = insitu_calibration::simulation;

namespace
{
const std::string kSource = INSITU_SOURCE_DIR;

sim::SurveySimulator makeSimulator(double duration_s, bool odom_drift)
{
  auto world = sim::loadWorldFile(kSource + "/config/worlds/waiting_room.yaml");
  EXPECT_TRUE(world);
  sim::SimulationOptions o;
  o.seed = 5;
  o.duration_s = duration_s;
  o.localization_sigma_m = 0.02;
  o.localization_sigma_deg = 0.5;
  o.localization_tau_s = 5.0;
  o.odom_drift = odom_drift;
  auto s = sim::SurveySimulator::create(*world, o);
  EXPECT_TRUE(s);
  return std::move(*s);
}
}  // namespace

TEST(Localization, TfCarriesTheErrorAndOdometryTheTruth)
{
  const sim::SurveySimulator s = makeSimulator(20.0, true);
  for (const int64_t t : {int64_t(0), int64_t(3050000000), int64_t(17200000000)})
  {
    const auto tf = s.dynamicTransforms(t);
    ASSERT_EQ(tf.size(), 2u);
    const Eigen::Isometry3d map_from_base = tf[0].transform * tf[1].transform;
    EXPECT_LT((map_from_base.matrix() - s.localizedMapFromBase(t).matrix()).norm(), 1e-9);
    const sim::Pose2d e = s.localizationError(t);
    const Eigen::Vector3d offset = map_from_base.translation() - s.mapFromBase(t).translation();
    EXPECT_NEAR(offset.x(), e.x, 1e-9);
    EXPECT_NEAR(offset.y(), e.y, 1e-9);
    EXPECT_GT(std::hypot(e.x, e.y), 1e-6);  // it errs
  }
}

TEST(Localization, ErrorHasTheStatedSizeAndCorrelation)
{
  const sim::SurveySimulator s = makeSimulator(2000.0, false);
  const int64_t step = 50000000;  // the tf period
  double sum_x = 0.0, sum_yaw = 0.0, sum_step = 0.0;
  int n = 0;
  sim::Pose2d previous = s.localizationError(0);
  for (int64_t t = step; t < s.durationNs(); t += step, ++n)
  {
    const sim::Pose2d e = s.localizationError(t);
    sum_x += e.x * e.x;
    sum_yaw += e.yaw * e.yaw;
    sum_step += (e.x - previous.x) * (e.x - previous.x);
    previous = e;
  }
  // 400 correlation times: the standard deviations within 15 %; one tf step (0.05 s of 5 s) moves the error by
  // sigma sqrt(2 dt / tau) = 0.14 sigma.
  EXPECT_NEAR(std::sqrt(sum_x / n), 0.02, 0.003);
  EXPECT_NEAR(std::sqrt(sum_yaw / n) * 180.0 / M_PI, 0.5, 0.075);
  EXPECT_NEAR(std::sqrt(sum_step / n), 0.02 * std::sqrt(2.0 * 0.05 / 5.0), 0.0005);
}

TEST(Localization, PlacementLimitIsTheAveragedError)
{
  std::vector<sim::LocalizationSample> errors = {{1.0, {0.01, 0.0, 0.0}}, {2.0, {0.03, 0.02, 0.0}}};
  const auto limit = sim::placementLimit(errors, {1.0, 2.0}, {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()},
                                         Eigen::Vector3d(5.0, 0.0, 0.0));
  EXPECT_NEAR(limit.position_m, std::hypot(0.02, 0.01), 1e-12);
  EXPECT_NEAR(limit.rotation_rad, 0.0, 1e-12);
  errors = {{1.0, {0.0, 0.0, 0.01}}};
  const auto turned = sim::placementLimit(errors, {1.0}, {Eigen::Vector3d::Zero()}, Eigen::Vector3d(2.0, 0.0, 0.0));
  EXPECT_NEAR(turned.rotation_rad, 0.01, 1e-12);
  EXPECT_NEAR(turned.position_m, 2.0 * 2.0 * std::sin(0.005), 1e-9);  // the chord of a 0.01 rad turn at 2 m
}

// Two recordings whose clocks overlap: each keyframe's error is its own recording's, the limit their average.
TEST(Localization, PlacementLimitOverRecordingsAveragesEveryKeyframesOwnError)
{
  const std::vector<sim::LocalizationSample> first = {{1.0, {0.02, 0.0, 0.0}}, {2.0, {0.04, 0.0, 0.0}}};
  const std::vector<sim::LocalizationSample> second = {{1.0, {-0.02, 0.01, 0.0}}, {2.0, {0.0, 0.01, 0.0}}};
  EXPECT_DOUBLE_EQ(sim::nearestLocalizationSample(first, 1.4).error.x, 0.02);
  EXPECT_DOUBLE_EQ(sim::nearestLocalizationSample(first, 1.6).error.x, 0.04);
  EXPECT_DOUBLE_EQ(sim::nearestLocalizationSample(first, 9.0).error.x, 0.04);
  EXPECT_DOUBLE_EQ(sim::nearestLocalizationSample(second, -3.0).error.x, -0.02);
  const std::vector<sim::Pose2d> keyframes = {
      sim::nearestLocalizationSample(first, 1.0).error, sim::nearestLocalizationSample(first, 2.0).error,
      sim::nearestLocalizationSample(second, 1.0).error, sim::nearestLocalizationSample(second, 2.0).error};
  const std::vector<Eigen::Vector3d> pivots(4, Eigen::Vector3d::Zero());
  const auto limit = sim::placementLimit(keyframes, pivots, Eigen::Vector3d(3.0, 1.0, 2.0));
  EXPECT_NEAR(limit.position_m, std::hypot(0.01, 0.005), 1e-12);  // mean x (0.02 + 0.04 - 0.02 + 0) / 4, mean y
  // One recording alone, by stamps, is the same as by its keyframes' errors.
  const auto by_stamps = sim::placementLimit(first, {1.0, 2.0}, {pivots[0], pivots[1]}, Eigen::Vector3d::Zero());
  const auto by_keyframes =
      sim::placementLimit({keyframes[0], keyframes[1]}, {pivots[0], pivots[1]}, Eigen::Vector3d::Zero());
  EXPECT_DOUBLE_EQ(by_stamps.position_m, by_keyframes.position_m);
  EXPECT_NEAR(by_stamps.position_m, 0.03, 1e-12);
}
