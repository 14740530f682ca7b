// The ambiguity test of the final check (view_ambiguity.h): a camera one tile off in a hall of floor tiles and a row
// of identical wall panels, all repeating every metre, explains its image exactly as well as the true camera; the other
// checks accept it, the ambiguity test refuses it with the reason. The true camera of a room that does not repeat is
// accepted (the test does not refuse everything). An alternative is dismissed only by a check that says it is wrong,
// not by one that says it is weakly determined (too few lines). A repetition not tried as one is still found by the
// neighbourhood of starts. A start ending at the same camera with a better explanation replaces the search's result.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/geometry/optical_frame.h"
#include "insitu_calibration/survey/fixed_camera.h"
#include "insitu_calibration/survey/view_ambiguity.h"
#include "insitu_calibration/test_support/line_scene.h"

namespace ic = insitu_calibration;

namespace
{
constexpr int kWidth = 640, kHeight = 480;
constexpr double kFocal = 520.0;
constexpr int kTiles = 24;  // a 24 x 24 m floor of 1 m tiles: the camera sees none of its borders

ic::CameraModel cameraLookingAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target)
{
  ic::Intrinsics k;
  k.fx = k.fy = kFocal;
  k.cx = 0.5 * (kWidth - 1) + 3.0;
  k.cy = 0.5 * (kHeight - 1) - 2.0;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() = *ic::opticalRotationLookingAlong(target - position);
  world_from_camera.translation() = position;
  return ic::CameraModel(k, ic::DivisionModel{0.0, k.principalPoint()},
                         ic::CameraPose::fromWorldFromCamera(world_from_camera));
}

// A light floor with dark tiles in a checkerboard (1 mm above it: no z-fighting) and, along its far side, a 4 m
// wall with a row of identical panels every metre (a plane alone leaves the camera undetermined); the map: the tile
// edges as lines running the whole floor, the wall's top and the panels' edges.
ic::LineScene tiledHall(std::vector<ic::Segment3d>* map)
{
  ic::LineScene s;
  s.quads.push_back({{0, 0, 0}, {kTiles, 0, 0}, {0, kTiles, 0}, 175.0});
  for (int i = 0; i < kTiles; ++i)
    for (int j = 0; j < kTiles; ++j)
      if ((i + j) % 2 == 0)
        s.quads.push_back({{double(i), double(j), 0.001}, {1, 0, 0}, {0, 1, 0}, 70.0});
  for (int i = 0; i <= kTiles; ++i)
  {
    map->push_back({Eigen::Vector3d(i, 0, 0), Eigen::Vector3d(i, kTiles, 0)});
    map->push_back({Eigen::Vector3d(0, i, 0), Eigen::Vector3d(kTiles, i, 0)});
  }
  s.quads.push_back({{0, kTiles, 0}, {kTiles, 0, 0}, {0, 0, 4.0}, 215.0});
  map->push_back({Eigen::Vector3d(0, kTiles, 4.0), Eigen::Vector3d(kTiles, kTiles, 4.0)});
  const double y = kTiles - 0.002, x0 = 0.2, width = 0.4, z0 = 0.8, z1 = 2.2;
  for (int i = 0; i < kTiles; ++i)
  {
    s.quads.push_back({{i + x0, y, z0}, {width, 0, 0}, {0, 0, z1 - z0}, 95.0});
    for (const double x : {i + x0, i + x0 + width})
      map->push_back({Eigen::Vector3d(x, y, z0), Eigen::Vector3d(x, y, z1)});
    for (const double z : {z0, z1})
      map->push_back({Eigen::Vector3d(i + x0, y, z), Eigen::Vector3d(i + x0 + width, y, z)});
  }
  return s;
}

cv::Mat render(const ic::LineScene& scene, const ic::CameraModel& camera)
{
  std::mt19937 rng(7);
  ic::LineSceneRenderOptions options;
  options.supersampling = 4;
  options.noise_sigma = 2.0;
  options.blur_sigma_px = 0.6;
  cv::Mat grey = ic::renderGrey(scene, camera, kWidth, kHeight, options, rng), rgb;
  cv::cvtColor(grey, rgb, cv::COLOR_GRAY2RGB);
  return rgb;
}

// The tiled hall seen by a camera above the floor looking at the wall, and the camera one tile along the wall from
// it (the same view).
struct HallView
{
  ic::LineScene hall;
  ic::CameraModel truth = cameraLookingAt({12.3, 17.0, 3.0}, {12.6, 22.0, 0.8});
  ic::CameraModel one_tile_off = ic::shiftedCamera(truth, Eigen::Vector3d(1.0, 0.0, 0.0), false, 0.0);
  cv::Mat image;
  explicit HallView(std::vector<ic::Segment3d>* map) : hall(tiledHall(map)), image(render(hall, truth)) {}
};

// A fixed camera whose installer's prior is the given camera (0.5 m, 2 deg, 5 %), with the image.
ic::FixedCamera fixedCamera(const ic::CameraModel& prior_camera, const cv::Mat& image,
                            const ic::FixedCameraOptions& options)
{
  ic::FixedCameraConfig config;
  config.name = "cam";
  config.image_topic = "/cam/image_raw";
  config.image_width = kWidth;
  config.image_height = kHeight;
  ic::CameraPrior prior;
  prior.position = prior_camera.pose().center();
  prior.position_sigma_m = 0.5;  // as installers give it: the checks accept a camera within 3 m
  prior.direction = prior_camera.pose().rotation.row(2).transpose();
  prior.direction_sigma_deg = 2.0;
  prior.horizontal_fov_deg = 2.0 * std::atan(0.5 * kWidth / kFocal) * 180.0 / M_PI;
  prior.fov_sigma_relative = 0.05;
  config.prior = prior;
  ic::FixedCamera camera(config, options);
  EXPECT_TRUE(camera.addImage(image));
  return camera;
}
}  // namespace

TEST(ViewAmbiguity, RepetitionsOfATiledFloor)
{
  std::vector<ic::Segment3d> map;
  tiledHall(&map);
  const std::vector<ic::Segment3d> matched(map.begin() + 20, map.begin() + 30);  // floor lines of both directions
  const auto shifts = ic::findRepetitionShifts(map, matched);
  ASSERT_EQ(shifts.size(), 2u);  // 1 m along x and along y; 2 m and more are multiples
  for (const auto& s : shifts)
  {
    EXPECT_NEAR(s.shift.norm(), 1.0, 1e-9);
    EXPECT_NEAR(std::abs(s.shift.x()) + std::abs(s.shift.y()), 1.0, 1e-9);
    EXPECT_EQ(s.support, 5u);
  }
}

TEST(ViewAmbiguity, TheTileIsTriedWhenItsMultiplesAreBetterSupported)
{
  // Floor tile edges every 0.37 m along x, three of them matched, and on three walls rows of panels repeating every
  // 1.11, 1.48 and 1.85 m (3, 4 and 5 tiles), four panel edges of each matched: the rows' periods are better
  // supported than the tile's and fill max_periods, yet a camera one tile off is what a tiled view risks.
  constexpr double kTile = 0.37;
  std::vector<ic::Segment3d> map, matched;
  for (int k = 0; k <= 8; ++k)
    map.push_back({Eigen::Vector3d(kTile * k, 0, 0), Eigen::Vector3d(kTile * k, 4, 0)});
  matched = {map[0], map[4], map[8]};
  const double rows[3] = {3 * kTile, 4 * kTile, 5 * kTile};
  for (int w = 0; w < 3; ++w)
    for (int k = 0; k < 5; ++k)
    {
      const double y = 10.0 + 10.0 * w;  // the walls farther apart than max_period_m
      const ic::Segment3d edge{Eigen::Vector3d(rows[w] * k, y, 0.5), Eigen::Vector3d(rows[w] * k, y, 2.0)};
      map.push_back(edge);
      if (k < 4)
        matched.push_back(edge);
    }
  const ic::ViewAmbiguityOptions options;
  const auto shifts = ic::findRepetitionShifts(map, matched, options);
  ASSERT_GT(shifts.size(), options.max_periods);
  bool tile = false;
  for (const auto& s : shifts)
    tile = tile || (s.shift - Eigen::Vector3d(kTile, 0, 0)).norm() < 1e-9;
  EXPECT_TRUE(tile) << "the 0.37 m tile is not among the " << shifts.size() << " periods tried";
  for (const double row : rows)
    EXPECT_TRUE(
        std::any_of(shifts.begin(), shifts.begin() + options.max_periods,
                    [&](const ic::RepetitionShift& s) { return (s.shift - Eigen::Vector3d(row, 0, 0)).norm() < 1e-9; }))
        << "the row of " << row << " m is not among the best supported";
}

TEST(ViewAmbiguity, CameraOneTileOffInATiledHallIsRefused)
{
  std::vector<ic::Segment3d> map;
  const HallView view(&map);
  const ic::CameraModel& truth = view.truth;
  const cv::Mat& image = view.image;
  // The installer's prior places the camera one tile along the wall from where it is: the view is the same.
  const ic::CameraModel& wrong = view.one_tile_off;

  // The prior search alone, which stays on the prior's tile (hypotheses from anywhere in the prior's cone may land on
  // any tile, here mostly the true one: the view is the same from each).
  ic::FixedCameraOptions checks;
  checks.matcher.hypothesis_starts = 0;
  ic::FixedCameraOptions without = checks;
  without.ambiguity.enabled = false;
  ic::FixedCamera unchecked = fixedCamera(wrong, image, without);
  const auto accepted = unchecked.calibrate(map, "world");
  ASSERT_TRUE(accepted) << accepted.error().describe();  // the other checks let the wrong camera through
  const double off = (accepted->calibration.camera.pose().center() - truth.pose().center()).norm();
  std::printf("without the ambiguity test: accepted %.3f m from the truth: %s\n", off, accepted->summary.c_str());
  EXPECT_NEAR(off, 1.0, 0.05);

  ic::FixedCamera checked = fixedCamera(wrong, image, checks);
  const auto refused = checked.calibrate(map, "world");
  if (refused)
    std::printf("accepted: %s\n", refused->summary.c_str());
  ASSERT_FALSE(refused);
  const std::string message = refused.error().message();
  std::printf("refused: %s\n", message.c_str());
  EXPECT_EQ(refused.error().code(), ic::ErrorCode::kNoSolution);
  EXPECT_NE(message.find("the view repeats"), std::string::npos);
  EXPECT_NE(message.find("every 1.00 m"), std::string::npos);
  EXPECT_NE(message.find("survey a distinctive feature"), std::string::npos);
  ASSERT_TRUE(checked.lastRefused());
  EXPECT_GT(checked.lastRefused()->ambiguity.tried, 0u);
  EXPECT_FALSE(checked.calibration());

  // With the default search (hypothesis starts too) the view is as ambiguous, whichever tile the search ends on.
  ic::FixedCamera by_default = fixedCamera(wrong, image, {});
  const auto default_result = by_default.calibrate(map, "world");
  ASSERT_FALSE(default_result);
  EXPECT_NE(default_result.error().message().find("the view repeats"), std::string::npos);
}

TEST(ViewAmbiguity, TrueCameraOfARoomThatDoesNotRepeatIsAccepted)
{
  std::mt19937 rng(3);
  const ic::LineScene room = ic::makeRoomScene(rng);
  const std::vector<ic::Segment3d> map = room.edges();
  const ic::CameraModel truth = cameraLookingAt({5.6, 4.6, 2.3}, {2.0, 1.5, 0.9});
  const cv::Mat image = render(room, truth);
  const ic::CameraModel prior = ic::shiftedCamera(truth, Eigen::Vector3d(0.05, -0.05, 0.03), false, 0.0);

  ic::FixedCamera camera = fixedCamera(prior, image, {});
  const auto result = camera.calibrate(map, "world");
  ASSERT_TRUE(result) << result.error().describe();
  std::printf("%s\n", result->summary.c_str());
  EXPECT_LT((result->calibration.camera.pose().center() - truth.pose().center()).norm(), 0.02);
  EXPECT_NEAR(result->calibration.camera.intrinsics().fx, kFocal, 0.005 * kFocal);
  // The room's parallel edges (doors, posters, boxes) gave repetitions to try: the test ran and found none as good.
  EXPECT_GT(result->ambiguity.tried, 0u);
}

TEST(ViewAmbiguity, OnlyACheckSayingTheAlternativeIsWrongDismissesIt)
{
  EXPECT_FALSE(ic::dismissedByOwnChecks(ic::Success{}));
  EXPECT_TRUE(ic::dismissedByOwnChecks(ic::Error(ic::ErrorCode::kNoSolution, "the focal length is implausible")));
  // Weakly determined: says nothing against the alternative.
  EXPECT_FALSE(ic::dismissedByOwnChecks(ic::Error(ic::ErrorCode::kDegenerate, "determined too weakly")));
  EXPECT_FALSE(ic::dismissedByOwnChecks(ic::Error(ic::ErrorCode::kNotEnoughData, "only 7 lines matched")));
}

// The hall, with two panel edges missing from the map at the borders of the view (unsurveyed there): the true
// camera, and the one two tiles from it, each miss one map line for an image line the camera one tile off explains.
// With the final check needing as many matched lines as that wrong camera has, the check accepts it, and its two
// neighbours, explaining the image as well, fail their own checks only for too few lines. That is no evidence
// against them: the view still repeats.
TEST(ViewAmbiguity, AnAlternativeWithTooFewLinesStillMakesTheViewRepeat)
{
  std::vector<ic::Segment3d> full_map, map;
  const HallView view(&full_map);
  const ic::CameraModel& truth = view.truth;
  const cv::Mat& image = view.image;
  const ic::CameraModel& wrong = view.one_tile_off;
  // Panel 9's left edge (x 9.2, the true camera's leftmost whole panel) and panel 18's right edge (x 18.6: what the
  // camera two tiles off takes the true camera's panel 16 for); the camera one tile off sees neither.
  for (const ic::Segment3d& line : full_map)
    if (!(line.a.y() > 23.0 && line.a.x() == line.b.x() &&
          (std::abs(line.a.x() - 9.2) < 1e-9 || std::abs(line.a.x() - 18.6) < 1e-9)))
      map.push_back(line);
  ASSERT_EQ(map.size(), full_map.size() - 2);

  ic::FixedCameraOptions without;
  without.matcher.hypothesis_starts = 0;  // the prior search alone: it stays on the prior's tile
  without.ambiguity.enabled = false;
  ic::FixedCamera unchecked = fixedCamera(wrong, image, without);
  const auto accepted = unchecked.calibrate(map, "world");
  ASSERT_TRUE(accepted) << accepted.error().describe();
  ASSERT_NEAR((accepted->calibration.camera.pose().center() - truth.pose().center()).norm(), 1.0, 0.05);
  const size_t matched = accepted->matched_map_lines.size();

  ic::FixedCameraOptions checks = without;
  checks.ambiguity.enabled = true;
  checks.min_matched_lines = matched;  // the wrong camera just passes; its neighbours, one line short, do not
  ic::FixedCamera checked = fixedCamera(wrong, image, checks);
  const auto refused = checked.calibrate(map, "world");
  ASSERT_TRUE(checked.lastRefused() || refused);
  const ic::ViewAmbiguity& ambiguity = refused ? refused->ambiguity : checked.lastRefused()->ambiguity;
  std::printf("%s\n", ambiguity.describe().c_str());
  // The true camera is among the alternatives: one line short, explaining the image about as well.
  const auto true_alternative =
      std::find_if(ambiguity.alternatives.begin(), ambiguity.alternatives.end(), [&](const ic::AlternativeCamera& a) {
        return (a.calibration.camera.pose().center() - truth.pose().center()).norm() < 0.02;
      });
  ASSERT_NE(true_alternative, ambiguity.alternatives.end());
  EXPECT_LT(true_alternative->matched_lines, matched);
  EXPECT_TRUE(ic::explainsAsWell(*true_alternative, ambiguity, checks.ambiguity));

  ASSERT_FALSE(refused) << "accepted " << refused->summary;
  EXPECT_EQ(refused.error().code(), ic::ErrorCode::kNoSolution);
  EXPECT_NE(refused.error().message().find("the view repeats"), std::string::npos) << refused.error().message();
}

TEST(ViewAmbiguity, NeighbourhoodIsTheFacesAndCornersOfACubeAroundTheCamera)
{
  const ic::CameraModel camera = cameraLookingAt({1.0, 2.0, 3.0}, {6.0, 4.0, 0.5});
  const Eigen::Vector3d axis = camera.pose().rotation.row(2).transpose();
  const auto shifts = ic::neighbourhoodShifts(camera, 0.4);
  ASSERT_EQ(shifts.size(), 14u);
  size_t along_axis = 0, horizontal_across = 0;
  for (const Eigen::Vector3d& s : shifts)
  {
    EXPECT_NEAR(s.norm(), 0.4, 1e-12);
    along_axis += std::abs(std::abs(s.normalized().dot(axis)) - 1.0) < 1e-12;
    horizontal_across += std::abs(s.z()) < 1e-12 && std::abs(s.dot(axis)) < 1e-12;
    // Each once, and its opposite too.
    EXPECT_EQ(
        std::count_if(shifts.begin(), shifts.end(), [&](const Eigen::Vector3d& t) { return (t - s).norm() < 1e-9; }),
        1);
    EXPECT_EQ(
        std::count_if(shifts.begin(), shifts.end(), [&](const Eigen::Vector3d& t) { return (t + s).norm() < 1e-9; }),
        1);
  }
  EXPECT_EQ(along_axis, 2u);
  EXPECT_EQ(horizontal_across, 2u);
  // A camera looking straight down has no horizontal sideways direction from its axis: its own x is used.
  const auto down = ic::neighbourhoodShifts(cameraLookingAt({0, 0, 3}, {0, 0, 0}), 0.2);
  ASSERT_EQ(down.size(), 14u);
  for (const Eigen::Vector3d& s : down)
    EXPECT_NEAR(s.norm(), 0.2, 1e-12);
}

// The tiled hall again, with no repetition of the map tried (as a shelf's 0.14 m rows, shorter than the periods the
// test counts, or door frames the map shows only beside unmatched lines are none): the camera one tile off passes.
// The neighbourhood of starts, at a radius of about one tile, reaches the true camera.
TEST(ViewAmbiguity, NeighbourhoodFindsARepetitionTheMapDoesNotShow)
{
  std::vector<ic::Segment3d> map;
  const HallView view(&map);
  const ic::CameraModel& truth = view.truth;
  const ic::CameraModel& wrong = view.one_tile_off;

  ic::FixedCameraOptions without;
  without.matcher.hypothesis_starts = 0;  // the prior search alone: it stays on the prior's tile
  without.ambiguity.max_periods = 0;      // no repetition of the map is tried: the tile is none to the test
  without.ambiguity.neighbourhood_share = 0.0;
  ic::FixedCamera unchecked = fixedCamera(wrong, view.image, without);
  const auto accepted = unchecked.calibrate(map, "world");
  ASSERT_TRUE(accepted) << accepted.error().describe();
  const ic::CameraModel& found = accepted->calibration.camera;
  ASSERT_NEAR((found.pose().center() - truth.pose().center()).norm(), 1.0, 0.05);
  EXPECT_EQ(accepted->ambiguity.periods, 0u);

  // The scene's depth as the test measures it (the median depth of the matched lines): a radius of one tile.
  std::vector<double> depths;
  for (const ic::Segment3d& l : accepted->matched_map_lines)
    depths.push_back((found.pose().rotation * (0.5 * (l.a + l.b)) + found.pose().translation).z());
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  ic::FixedCameraOptions checks = without;
  checks.ambiguity.neighbourhood_share = 1.0 / depths[depths.size() / 2];
  ic::FixedCamera checked = fixedCamera(wrong, view.image, checks);
  const auto refused = checked.calibrate(map, "world");
  ASSERT_FALSE(refused) << "accepted " << refused->summary;
  std::printf("refused: %s\n", refused.error().message().c_str());
  EXPECT_EQ(refused.error().code(), ic::ErrorCode::kNoSolution);
  EXPECT_NE(refused.error().message().find("the view does not decide the camera"), std::string::npos);
  ASSERT_TRUE(checked.lastRefused());
  const auto& alternatives = checked.lastRefused()->ambiguity.alternatives;
  EXPECT_TRUE(std::any_of(alternatives.begin(), alternatives.end(), [&](const ic::AlternativeCamera& a) {
    return a.from_neighbourhood && (a.calibration.camera.pose().center() - truth.pose().center()).norm() < 0.02;
  })) << "no start of the neighbourhood reached the true camera";
}

namespace
{
// An alternative of `accepted` at a shift of its centre, with a score and matched lines, compared as the test does.
ic::AlternativeCamera alternativeAt(const ic::CameraCalibration& accepted, const Eigen::Vector3d& shift, double score,
                                    size_t matched_lines)
{
  ic::AlternativeCamera alt;
  alt.calibration = accepted;
  alt.calibration.camera = ic::shiftedCamera(accepted.camera, shift, false, 0.0);
  alt.score = score;
  alt.matched_lines = matched_lines;
  alt.clearly_different = shift.norm() > ic::ViewAmbiguityOptions().min_position_m;
  return alt;
}

// An accepted camera's test (score 50, 20 matched lines) with no alternative yet.
struct AcceptedCamera
{
  ic::CameraCalibration calibration;
  ic::ViewAmbiguity ambiguity;
  AcceptedCamera()
  {
    calibration.camera = cameraLookingAt({1.0, 2.0, 3.0}, {6.0, 4.0, 0.5});
    ambiguity.accepted_score = 50.0;
    ambiguity.accepted_matched = 20;
  }
};
}  // namespace

// The search's result replaced by a start at the same camera explaining the image better: only one not clearly
// different, with at least as many lines, better by the margin; the best of several.
TEST(ViewAmbiguity, SameCameraExplainingBetterReplacesTheSearchsResult)
{
  AcceptedCamera test;
  const ic::CameraCalibration& accepted = test.calibration;
  ic::ViewAmbiguity& ambiguity = test.ambiguity;
  const ic::ViewAmbiguityOptions options;
  ambiguity.alternatives = {
      alternativeAt(accepted, {0.4, 0.0, 0.0}, 40.0, 25),   // clearly different: the ambiguity test's, not this
      alternativeAt(accepted, {0.01, 0.0, 0.0}, 45.0, 19),  // fewer lines
      alternativeAt(accepted, {0.0, 0.01, 0.0}, 49.8, 22),  // better by less than the margin
  };
  EXPECT_FALSE(ic::sameCameraExplainingBetter(ambiguity, options));
  ambiguity.alternatives.push_back(alternativeAt(accepted, {0.0, 0.0, 0.01}, 48.9, 21));
  ambiguity.alternatives.push_back(alternativeAt(accepted, {0.0, 0.02, 0.0}, 48.2, 20));
  const auto taken = ic::sameCameraExplainingBetter(ambiguity, options);
  ASSERT_TRUE(taken);
  EXPECT_EQ(*taken, 4u);
  ic::ViewAmbiguityOptions never = options;
  never.better_score_margin = 0.0;
  EXPECT_FALSE(ic::sameCameraExplainingBetter(ambiguity, never));
}

// After the replacement the test reads as if the taken start had been accepted: the other alternatives compared with
// it, the replaced camera one of them (a nearby optimum), and the replaced score kept for the summary.
TEST(ViewAmbiguity, AfterTheReplacementTheAlternativesAreComparedWithTheTakenCamera)
{
  AcceptedCamera test;
  const ic::CameraCalibration& accepted = test.calibration;
  ic::ViewAmbiguity& ambiguity = test.ambiguity;
  const ic::ViewAmbiguityOptions options;
  ambiguity.alternatives = {alternativeAt(accepted, {0.4, 0.0, 0.0}, 60.0, 15),
                            alternativeAt(accepted, {0.0, 0.03, 0.0}, 48.0, 22)};
  ambiguity.alternatives[0].dismissed = "explains less";
  const ic::ViewAmbiguity after = ic::withAcceptedAlternative(ambiguity, 1, accepted, options);
  EXPECT_DOUBLE_EQ(after.accepted_score, 48.0);
  EXPECT_EQ(after.accepted_matched, 22u);
  EXPECT_DOUBLE_EQ(after.replaced_score, 50.0);
  EXPECT_EQ(after.replaced_matched, 20u);
  ASSERT_EQ(after.alternatives.size(), 2u);
  // The one 0.4 m along x from the replaced camera: measured from the taken one, judged afresh.
  EXPECT_NEAR(after.alternatives[0].position_difference_m, std::hypot(0.4, 0.03), 1e-9);
  EXPECT_TRUE(after.alternatives[0].clearly_different);
  EXPECT_TRUE(after.alternatives[0].dismissed.empty());
  // The replaced camera, 3 cm away: the same camera, with its score and lines.
  const ic::AlternativeCamera& replaced = after.alternatives[1];
  EXPECT_NEAR(replaced.position_difference_m, 0.03, 1e-9);
  EXPECT_FALSE(replaced.clearly_different);
  EXPECT_TRUE(replaced.from_neighbourhood);
  EXPECT_TRUE(replaced.replaced_result);
  EXPECT_FALSE(after.alternatives[0].replaced_result);
  EXPECT_DOUBLE_EQ(replaced.score, 50.0);
  EXPECT_EQ(replaced.matched_lines, 20u);
  EXPECT_NE(after.describe().find("replaced by a start at the same camera"), std::string::npos) << after.describe();
}
