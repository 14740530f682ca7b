// The matcher's ranking (matching_problem.h, internal to src/core/matching): a result beyond the prior's distance
// limit ranks behind every nearer one however well it explains the image, and only then.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "../../src/core/matching/matching_problem.h"
#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

namespace ic = insitu_calibration;

namespace
{
constexpr int kWidth = 1280;
constexpr int kHeight = 960;

// The image of the true camera's lines: polylines of 4 points, noise-free.
std::vector<std::vector<Eigen::Vector2d>> imageOf(const ic::CameraModel& camera,
                                                  const std::vector<ic::Segment3d>& lines)
{
  std::vector<std::vector<Eigen::Vector2d>> image;
  for (const auto& s : lines)
  {
    std::vector<Eigen::Vector2d> polyline;
    for (int k = 0; k < 4; ++k)
      polyline.push_back(*camera.project(s.pointAt(k / 3.0)));
    image.push_back(polyline);
  }
  return image;
}

// The camera moved by `offset` in the world, looking the same way.
ic::CameraModel movedBy(const ic::CameraModel& camera, const Eigen::Vector3d& offset)
{
  ic::CameraModel moved = camera;
  Eigen::Isometry3d world_from_camera = camera.pose().worldFromCamera();
  world_from_camera.translation() += offset;
  moved.pose() = ic::CameraPose::fromWorldFromCamera(world_from_camera);
  return moved;
}

struct RankingScene
{
  ic::CameraModel truth;
  std::vector<ic::Segment3d> map;
  std::vector<std::vector<Eigen::Vector2d>> image;
  std::vector<double> no_sigmas;
  ic::LineMatcherOptions options;
  ic::CameraPrior prior;  // 2 m from the truth, 0.2 m sigma: the truth lies 10 sigmas away
};

RankingScene makeScene()
{
  RankingScene scene;
  std::mt19937 rng(7);
  scene.truth = ic::randomCamera(ic::SyntheticCameraOptions{}, rng);
  ic::SyntheticLineOptions line_options;
  line_options.axis_aligned = true;
  scene.map = ic::makeSyntheticLines(scene.truth, kWidth, kHeight, line_options, rng).segments;
  scene.image = imageOf(scene.truth, scene.map);
  scene.options.max_prior_distance_sigmas = 6.0;
  scene.prior.position = scene.truth.pose().center() + Eigen::Vector3d(2.0, 0.0, 0.0);
  scene.prior.position_sigma_m = 0.2;
  return scene;
}
}  // namespace

TEST(MatchRanking, AResultBeyondThePriorsDistanceRanksLastHoweverWellItExplains)
{
  RankingScene scene = makeScene();
  ic::matching::MatchingProblem problem(scene.map, scene.no_sigmas, scene.image, kWidth, kHeight, scene.options);
  problem.prior = &scene.prior;
  // A camera at the prior explains the image worse than the truth, 2 m (10 sigmas) from the prior.
  const ic::CameraModel at_prior = movedBy(scene.truth, Eigen::Vector3d(2.0, 0.0, 0.0));
  const double truth_explains = ic::matching::explanationScore(scene.truth, problem);
  const double at_prior_explains = ic::matching::explanationScore(at_prior, problem);
  ASSERT_LT(truth_explains, at_prior_explains);

  EXPECT_DOUBLE_EQ(ic::matching::rankingScore(at_prior, problem), at_prior_explains);
  EXPECT_DOUBLE_EQ(ic::matching::rankingScore(scene.truth, problem),
                   truth_explains + ic::matching::kFarFromPriorPenalty);
  EXPECT_GT(ic::matching::rankingScore(scene.truth, problem), ic::matching::rankingScore(at_prior, problem));
}

TEST(MatchRanking, TheLimitIsTheOptionsNumberOfPositionSigmas)
{
  RankingScene scene = makeScene();
  ic::matching::MatchingProblem problem(scene.map, scene.no_sigmas, scene.image, kWidth, kHeight, scene.options);
  problem.prior = &scene.prior;
  // 6 sigmas of 0.2 m: 1.2 m. From the prior, 1.1 m ranks by its explanation, 1.3 m last.
  const ic::CameraModel within = movedBy(scene.truth, Eigen::Vector3d(0.9, 0.0, 0.0));
  const ic::CameraModel beyond = movedBy(scene.truth, Eigen::Vector3d(0.7, 0.0, 0.0));
  EXPECT_DOUBLE_EQ(ic::matching::rankingScore(within, problem), ic::matching::explanationScore(within, problem));
  EXPECT_GT(ic::matching::rankingScore(beyond, problem), ic::matching::kFarFromPriorPenalty);
}

TEST(MatchRanking, WithoutAPriorOrALimitTheExplanationAloneRanks)
{
  RankingScene scene = makeScene();
  const ic::CameraModel at_prior = movedBy(scene.truth, Eigen::Vector3d(2.0, 0.0, 0.0));
  {
    ic::matching::MatchingProblem problem(scene.map, scene.no_sigmas, scene.image, kWidth, kHeight, scene.options);
    EXPECT_DOUBLE_EQ(ic::matching::rankingScore(scene.truth, problem),
                     ic::matching::explanationScore(scene.truth, problem));
  }
  scene.options.max_prior_distance_sigmas = 0.0;
  ic::matching::MatchingProblem problem(scene.map, scene.no_sigmas, scene.image, kWidth, kHeight, scene.options);
  problem.prior = &scene.prior;
  EXPECT_LT(ic::matching::rankingScore(scene.truth, problem), ic::matching::rankingScore(at_prior, problem));
}
