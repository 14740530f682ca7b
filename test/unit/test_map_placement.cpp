// The map's placement (survey/map_placement.h): the localiser's error averaged over keyframes, as a Gauss-Markov
// process's mean against Monte Carlo draws of that process, recordings combined without assuming them independent,
// the keyframes that observed a camera's lines, and the placement at a camera.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "insitu_calibration/survey/map_placement.h"

namespace ic = insitu_calibration;

namespace
{
ic::Keyframe keyframeAt(double stamp, const Eigen::Vector3d& position, bool starts_recording = false)
{
  ic::Keyframe k;
  k.stamp = stamp;
  k.T_map_camera.translation() = position;
  k.starts_recording = starts_recording;
  return k;
}

// The RMS over draws of a unit stationary Gauss-Markov process's mean over the stamps (exact AR(1) steps).
double monteCarloMeanRms(const std::vector<double>& stamps, double tau, int draws, uint32_t seed)
{
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  double sum_sq = 0.0;
  for (int d = 0; d < draws; ++d)
  {
    double e = normal(rng), mean = e;
    for (size_t j = 1; j < stamps.size(); ++j)
    {
      const double rho = std::exp(-(stamps[j] - stamps[j - 1]) / tau);
      e = rho * e + std::sqrt(1.0 - rho * rho) * normal(rng);
      mean += e;
    }
    mean /= static_cast<double>(stamps.size());
    sum_sq += mean * mean;
  }
  return std::sqrt(sum_sq / draws);
}
}  // namespace

TEST(MapPlacement, MeanErrorScaleIsTheGaussMarkovMeansSpread)
{
  EXPECT_DOUBLE_EQ(ic::meanErrorScale({}, 5.0), 0.0);
  EXPECT_DOUBLE_EQ(ic::meanErrorScale({3.0}, 5.0), 1.0);
  // Two stamps dt apart: sqrt(2 + 2 rho) / 2.
  EXPECT_NEAR(ic::meanErrorScale({0.0, 2.0}, 5.0), std::sqrt(2.0 + 2.0 * std::exp(-0.4)) / 2.0, 1e-12);
  // Independent keyframes (no correlation time): 1 / sqrt(n).
  EXPECT_NEAR(ic::meanErrorScale({0.0, 0.2, 0.4, 0.6}, 0.0), 0.5, 1e-12);
  // Dense over T >> tau: about sqrt(2 tau / T).
  std::vector<double> dense;
  for (double t = 0.0; t < 240.0; t += 0.2)
    dense.push_back(t);
  EXPECT_NEAR(ic::meanErrorScale(dense, 5.0), std::sqrt(2.0 * 5.0 / 240.0), 0.02 * std::sqrt(2.0 * 5.0 / 240.0));
  // Irregular stamps (two bursts and a gap, as a camera's lines are seen on two passes) against draws of the process.
  std::vector<double> bursts;
  for (double t = 10.0; t < 14.0; t += 0.2)
    bursts.push_back(t);
  for (double t = 41.0; t < 49.0; t += 0.4)
    bursts.push_back(t);
  const double predicted = ic::meanErrorScale(bursts, 5.0), drawn = monteCarloMeanRms(bursts, 5.0, 20000, 7);
  std::printf("two bursts: predicted %.4f, drawn %.4f\n", predicted, drawn);
  EXPECT_NEAR(drawn, predicted, 0.03 * predicted);
  // About three independent samples, not the 60 keyframes' 1 / sqrt(60) = 0.13.
  EXPECT_GT(predicted, 0.5);
}

TEST(MapPlacement, RecordingsAreCombinedForAnyCorrelationBetweenThem)
{
  const ic::LocaliserErrorModel model{0.02, 0.5, 5.0};
  std::vector<ic::Keyframe> one, two;
  std::vector<size_t> every_one, every_two;
  std::vector<double> stamps;
  for (int r = 0; r < 2; ++r)
    for (int k = 0; k < 300; ++k)  // 60 s each, the second recording's clock starting again (as simulated ones do)
    {
      const double t = 100.0 + 0.2 * k;
      two.push_back(keyframeAt(t, Eigen::Vector3d(0.01 * k, r, 0.0), r == 1 && k == 0));
      every_two.push_back(two.size() - 1);
      if (r == 0)
      {
        one.push_back(two.back());
        every_one.push_back(k);
        stamps.push_back(t);
      }
    }
  EXPECT_EQ(ic::recordingOf(two)[299], 0);
  EXPECT_EQ(ic::recordingOf(two)[300], 1);
  const auto single = ic::placementOverKeyframes(one, every_one, model);
  const auto both = ic::placementOverKeyframes(two, every_two, model);
  EXPECT_NEAR(single.sigma_m, 0.02 * ic::meanErrorScale(stamps, 5.0), 1e-12);
  EXPECT_NEAR(single.sigma_deg, 0.5 * ic::meanErrorScale(stamps, 5.0), 1e-12);
  // The same recording twice (a localiser that errs alike on a second drive) averages nothing more away; taken as
  // independent, the two would claim 1 / sqrt(2) of it.
  EXPECT_NEAR(both.sigma_m, single.sigma_m, 1e-12);
  EXPECT_NEAR(both.centre.y(), 0.5, 1e-12);
  EXPECT_EQ(both.keyframes, 600u);
  // A shorter second recording: the recordings' scales weighted by their keyframes.
  std::vector<ic::Keyframe> uneven(two.begin(), two.begin() + 400);
  std::vector<size_t> every_uneven(every_two.begin(), every_two.begin() + 400);
  const std::vector<double> short_stamps(stamps.begin(), stamps.begin() + 100);
  EXPECT_NEAR(ic::placementOverKeyframes(uneven, every_uneven, model).sigma_m,
              0.02 * (0.75 * ic::meanErrorScale(stamps, 5.0) + 0.25 * ic::meanErrorScale(short_stamps, 5.0)), 1e-12);
}

TEST(MapPlacement, TheKeyframesThatObservedTheLines)
{
  std::vector<ic::Keyframe> keyframes;
  for (int k = 0; k < 10; ++k)
    keyframes.push_back(keyframeAt(1.0 + k, Eigen::Vector3d::Zero()));
  for (int k = 0; k < 10; ++k)  // a second recording with the same stamps
    keyframes.push_back(keyframeAt(1.0 + k, Eigen::Vector3d::Zero(), k == 0));
  ic::MapLine depth;
  for (double stamp : {3.0, 5.0})
  {
    ic::MapObservation o;
    o.stamp = stamp;
    depth.observations.push_back(o);
  }
  ic::MapLine floor;  // no observations: its first to its last stamp
  floor.source = ic::MapLineSource::kFloor;
  floor.first_stamp = 7.0;
  floor.last_stamp = 8.0;
  ic::MapLine unseen;  // none at all (first after last, as an empty floor line's)
  unseen.first_stamp = 1.0 / 0.0;
  unseen.last_stamp = -1.0 / 0.0;
  EXPECT_EQ(ic::keyframesObserving(keyframes, {&depth, nullptr, &floor, &unseen}),
            (std::vector<size_t>{2, 4, 6, 7, 12, 14, 16, 17}));
  EXPECT_TRUE(ic::keyframesObserving(keyframes, {&unseen}).empty());
}

// At a point: the shift in both axes and the turn times the horizontal distance from the keyframes' centre.
TEST(MapPlacement, AtAPointTheShiftAndTheTurn)
{
  ic::MapPlacementUncertainty placement;
  placement.sigma_m = 0.004;
  placement.sigma_deg = 0.1;
  placement.centre = Eigen::Vector3d(3.0, 4.0, 0.0);
  EXPECT_NEAR(placement.atPoint(Eigen::Vector3d(3.0, 4.0, 2.5)), std::sqrt(2.0) * 0.004, 1e-12);  // above: no arm
  EXPECT_NEAR(placement.atPoint(Eigen::Vector3d(0.0, 0.0, 2.5)),
              std::hypot(std::sqrt(2.0) * 0.004, 0.1 * M_PI / 180.0 * 5.0), 1e-12);
}
