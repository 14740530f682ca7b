// The matcher finds the right 3D line for each image line from a rough prior and calibrates the camera.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <string>
#include <utility>

#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

namespace ic = insitu_calibration;

namespace
{
constexpr int kWidth = 1280;
constexpr int kHeight = 960;

void addBox(std::vector<ic::Segment3d>* out, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi)
{
  const Eigen::Vector3d d = hi - lo;
  for (int axis = 0; axis < 3; ++axis)
    for (int u = 0; u < 2; ++u)
      for (int v = 0; v < 2; ++v)
      {
        Eigen::Vector3d a = lo;
        a((axis + 1) % 3) += u * d((axis + 1) % 3);
        a((axis + 2) % 3) += v * d((axis + 2) % 3);
        Eigen::Vector3d b = a;
        b(axis) += d(axis);
        out->push_back({a, b});
      }
}

// A room of 8 x 6 x 3 m with furniture and posters: mostly axis-aligned edges, as in a building.
std::vector<ic::Segment3d> makeRoom(std::mt19937& rng)
{
  std::vector<ic::Segment3d> lines;
  addBox(&lines, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(8, 6, 3));
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 8; ++k)
  {
    const Eigen::Vector3d lo(1.0 + 5.5 * u(rng), 1.0 + 4.0 * u(rng), 0.0);
    addBox(&lines, lo, lo + Eigen::Vector3d(0.4 + 0.8 * u(rng), 0.4 + 0.8 * u(rng), 0.4 + 1.4 * u(rng)));
  }
  for (int k = 0; k < 6; ++k)  // posters on the far walls
  {
    const double x = 1.0 + 5.0 * u(rng);
    const double z = 0.8 + 1.2 * u(rng);
    addBox(&lines, Eigen::Vector3d(x, 5.99, z), Eigen::Vector3d(x + 0.6, 5.99, z + 0.8));
    const double y = 1.0 + 3.5 * u(rng);
    addBox(&lines, Eigen::Vector3d(7.99, y, z), Eigen::Vector3d(7.99, y + 0.7, z + 0.5));
  }
  return lines;
}

// A camera somewhere in the room (synthetic_lines.h's random camera) with a focal length in [focal_min, focal_max] px
// and square pixels, as the matcher's calibration takes them (LineMatcherOptions::calibration).
ic::CameraModel randomCamera(double focal_min_px, double focal_max_px, std::mt19937& rng)
{
  ic::SyntheticCameraOptions options;
  options.focal_min_px = focal_min_px;
  options.focal_max_px = focal_max_px;
  options.aspect_jitter = 0.0;
  return ic::randomCamera(options, rng);
}

std::vector<std::vector<Eigen::Vector2d>> imageLines(const ic::CameraModel& camera,
                                                     const std::vector<ic::Segment3d>& lines, double noise,
                                                     int spurious, std::mt19937& rng)
{
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::vector<Eigen::Vector2d>> out;
  for (const auto& s : lines)
  {
    const auto interval = ic::visibleInterval(camera, s, kWidth, kHeight);
    if (!interval)
      continue;
    std::vector<Eigen::Vector2d> polyline;
    for (int k = 0; k < 6; ++k)
    {
      const double t = interval->first + (interval->second - interval->first) * k / 5.0;
      polyline.push_back(*camera.project(s.pointAt(t)) + noise * Eigen::Vector2d(n(rng), n(rng)));
    }
    if ((polyline.back() - polyline.front()).norm() > 40.0)
      out.push_back(polyline);
  }
  for (int k = 0; k < spurious; ++k)
  {
    const Eigen::Vector2d a(u(rng) * kWidth, u(rng) * kHeight);
    const Eigen::Vector2d b = a + 150.0 * Eigen::Vector2d(n(rng), n(rng));
    out.push_back({a, 0.5 * (a + b), b});
  }
  return out;
}

// The installer's prior: the centre position_m off in a random direction, the viewing direction direction_deg off
// about a random axis across it, the horizontal field of view scaled by fov_scale.
ic::CameraPrior offPrior(const ic::CameraModel& truth, double position_m, double direction_deg, double fov_scale,
                         std::mt19937& rng)
{
  ic::CameraPrior prior;
  std::normal_distribution<double> n(0.0, 1.0);
  prior.position = truth.pose().center() + position_m * Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
  const Eigen::Vector3d axis = truth.pose().rotation.row(2).transpose();
  const Eigen::Vector3d tilt_axis = axis.cross(Eigen::Vector3d(n(rng), n(rng), n(rng))).normalized();
  prior.direction = Eigen::AngleAxisd(direction_deg * M_PI / 180.0, tilt_axis) * axis;
  prior.horizontal_fov_deg = 2.0 * std::atan(0.5 * kWidth / truth.intrinsics().fx) * 180.0 / M_PI * fov_scale;
  return prior;
}
}  // namespace

TEST(LineMatcher, ConvergesFromAnOffPrior)
{
  int converged = 0;
  const int trials = 6;
  for (int trial = 0; trial < trials; ++trial)
  {
    std::mt19937 rng(40 + trial);
    const std::vector<ic::Segment3d> room = makeRoom(rng);
    const ic::CameraModel truth = randomCamera(800, 1000, rng);
    const auto image = imageLines(truth, room, 0.3, 10, rng);

    // The installer's prior: 0.5 m off, the direction 10 degrees off, the field of view 20 % off.
    const ic::CameraPrior prior = offPrior(truth, 0.5, 10.0, trial % 2 ? 1.2 : 0.8, rng);

    const auto result = ic::matchAndCalibrate(room, image, prior, kWidth, kHeight);
    ASSERT_TRUE(result) << "trial " << trial << ": " << result.error().describe();
    const ic::CameraErrors e = ic::compareCameras(truth, result->calibration.camera);
    std::printf(
        "trial %d: %zu image lines, %zu matches, %d iterations, focal %.3f %%, rotation %.3f deg, "
        "position %.1f mm\n",
        trial, image.size(), result->matches.size(), result->iterations, 100 * e.focal_relative,
        e.rotation_rad * 180 / M_PI, 1000 * e.center_m);
    EXPECT_LT(std::abs(e.focal_relative), 0.01) << "trial " << trial;
    EXPECT_LT(e.rotation_rad * 180 / M_PI, 0.5) << "trial " << trial;
    EXPECT_LT(e.center_m, 0.03) << "trial " << trial;
    converged += result->converged ? 1 : 0;
  }
  EXPECT_EQ(converged, trials);
}

TEST(LineMatcher, RefusesEmptyInput)
{
  ic::CameraPrior prior;
  EXPECT_EQ(ic::matchAndCalibrate({}, {{{0, 0}, {1, 1}}}, prior, kWidth, kHeight).error().code(),
            ic::ErrorCode::kNotEnoughData);
  EXPECT_EQ(ic::matchAndCalibrate({{Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()}}, {}, prior, kWidth, kHeight)
                .error()
                .code(),
            ic::ErrorCode::kNotEnoughData);
  prior.horizontal_fov_deg = 0.0;
  EXPECT_EQ(ic::matchAndCalibrate({{Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()}}, {{{0, 0}, {1, 1}}}, prior,
                                  kWidth, kHeight)
                .error()
                .code(),
            ic::ErrorCode::kInvalidInput);
}

// Two map lines that project onto one image line are one edge mapped twice only when they are near in 3D too: a
// post's two edges seen edge-on (10 cm apart along the viewing ray, the same image line) leave the image line
// unmatched, since either match biases the camera; the same edge twice (5 mm apart) is matched.
TEST(LineMatcher, DistinctEdgesOnOneImageLineAreAmbiguous)
{
  std::mt19937 rng(17);
  const ic::CameraModel camera = randomCamera(900.0, 1100.0, rng);
  const Eigen::Vector3d centre = camera.pose().center();
  const Eigen::Matrix3d r = camera.pose().rotation;
  const Eigen::Vector3d forward = r.row(2).transpose();
  const Eigen::Vector3d up = -r.row(1).transpose();
  const Eigen::Vector3d middle = centre + 6.0 * forward + 0.8 * r.row(0).transpose();
  const ic::Segment3d edge{middle - 0.6 * up, middle + 0.6 * up};
  const Eigen::Vector3d ray = (middle - centre).normalized();
  std::vector<std::vector<Eigen::Vector2d>> image(1);
  for (int k = 0; k < 6; ++k)
    image[0].push_back(*camera.project(edge.pointAt(k / 5.0)));
  ASSERT_GT((image[0].back() - image[0].front()).norm(), 100.0);
  const ic::LineMatcherOptions options;
  for (const double apart_m : {0.10, 0.005})
  {
    const ic::Segment3d behind{edge.a + apart_m * ray, edge.b + apart_m * ray};
    const auto matches = ic::matchLines({edge, behind}, image, camera, kWidth, kHeight, 2.0, 4.0, options);
    SCOPED_TRACE("apart " + std::to_string(apart_m) + " m");
    EXPECT_EQ(matches.size(), apart_m > options.near_duplicate_m ? 0u : 1u);
    const auto alone = ic::matchLines({edge}, image, camera, kWidth, kHeight, 2.0, 4.0, options);
    EXPECT_EQ(alone.size(), 1u);  // the edge alone is matched: only the second line makes it ambiguous
  }
}

// The local moves run from the local_search_starts best refined starts that are distinct cameras: a start that
// refined to the same camera as a better one (within a few mm, 0.05 deg and 0.2 % focal length) is skipped, and the
// next distinct one takes its place.
TEST(LineMatcher, LocalMovesRunFromDistinctStarts)
{
  std::mt19937 rng(5);
  const ic::CameraModel c0 = ic::randomCamera({}, rng);
  const auto moved = [](ic::CameraModel c, const Eigen::Vector3d& centre_shift, double yaw_deg, double focal_scale) {
    const Eigen::Vector3d centre = c.pose().center() + centre_shift;
    c.pose().rotation = c.pose().rotation * Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY());
    c.pose().translation = -c.pose().rotation * centre;
    c.intrinsics().fx *= focal_scale;
    c.intrinsics().fy *= focal_scale;
    return c;
  };
  const std::vector<ic::CameraModel> refined = {
      c0,
      moved(c0, {0.002, -0.002, 0.0}, 0.0, 1.0),        // the same camera as start 1
      moved(c0, {0.05, 0.0, 0.0}, 0.0, 1.0),            // 5 cm away: distinct
      moved(c0, Eigen::Vector3d::Zero(), 0.03, 1.001),  // the same as start 1
      moved(c0, Eigen::Vector3d::Zero(), 0.0, 1.01),    // 1 % longer focal length: distinct
      moved(c0, {0.051, 0.001, 0.0}, 0.0, 1.0),         // the same as start 3
      moved(c0, Eigen::Vector3d::Zero(), 0.5, 1.0),     // 0.5 deg turned: distinct
  };
  ic::LineMatcherOptions options;
  options.local_search_starts = 3;
  EXPECT_EQ(ic::distinctStarts(refined, options), (std::vector<size_t>{0, 2, 4}));
  options.local_search_starts = 1;
  EXPECT_EQ(ic::distinctStarts(refined, options), (std::vector<size_t>{0}));
  options.local_search_starts = 0;  // at least the best start
  EXPECT_EQ(ic::distinctStarts(refined, options), (std::vector<size_t>{0}));
  options.local_search_starts = 10;  // as many as there are distinct ones
  EXPECT_EQ(ic::distinctStarts(refined, options), (std::vector<size_t>{0, 2, 4, 6}));
}

namespace
{
// The matcher's trace lines about the local moves: per explored start its score after them, and the chosen start.
struct LocalSearchTrace
{
  std::vector<std::pair<size_t, double>> explored;  // start (1-based), score after its local moves
  size_t chosen = 0, refined = 0;
  void read(const std::string& line)
  {
    size_t start = 0, count = 0;
    double score = 0.0;
    if (std::sscanf(line.c_str(), "local moves from start %zu: score %lf", &start, &score) == 2)
      explored.emplace_back(start, score);
    else if (std::sscanf(line.c_str(), "chosen: start %zu of %zu refined, %zu explored", &start, &refined, &count) == 3)
      chosen = start;
  }
};
}  // namespace

// A room seen from a prior 1 m, 15 deg and 30 % (field of view) off: the prior search and the hypotheses give 8
// refined starts, 6 of them the same camera. The local moves run from the best and the next two distinct starts, and
// the result explaining the image best wins; it is the true camera.
TEST(LineMatcher, LocalMovesFromSeveralDistinctStartsKeepTheBestExplanation)
{
  std::mt19937 rng(1000);
  const std::vector<ic::Segment3d> room = makeRoom(rng);
  const ic::CameraModel truth = randomCamera(700, 1300, rng);
  const auto image = imageLines(truth, room, 0.3, 15, rng);
  const ic::CameraPrior prior = offPrior(truth, 1.0, 15.0, 1.3, rng);

  for (const int starts : {1, 3})
  {
    LocalSearchTrace trace;
    ic::LineMatcherOptions options;
    options.local_search_starts = starts;
    options.trace = [&](const std::string& line) { trace.read(line); };
    const auto result = ic::matchAndCalibrate(room, image, prior, kWidth, kHeight, options);
    ASSERT_TRUE(result) << result.error().describe();
    const ic::CameraErrors e = ic::compareCameras(truth, result->calibration.camera);
    std::printf("%d local search starts: %zu of %zu refined explored; focal %.3f %%, rotation %.3f deg, %.1f mm\n",
                starts, trace.explored.size(), trace.refined, 100 * e.focal_relative, e.rotation_rad * 180 / M_PI,
                1000 * e.center_m);
    EXPECT_LT(std::abs(e.focal_relative), 0.01);
    EXPECT_LT(e.rotation_rad * 180 / M_PI, 0.5);
    EXPECT_LT(e.center_m, 0.03);
    ASSERT_EQ(trace.explored.size(), static_cast<size_t>(starts));
    EXPECT_EQ(trace.explored.front().first, 1u);  // the best refined start first
    // The distinct starts: not the refined starts 2 and 3, which are the best one's camera again.
    for (size_t k = 1; k < trace.explored.size(); ++k)
      EXPECT_GT(trace.explored[k].first, 3u) << "explored start " << k + 1;
    const auto best = std::min_element(trace.explored.begin(), trace.explored.end(),
                                       [](const auto& a, const auto& b) { return a.second < b.second; });
    EXPECT_EQ(trace.chosen, best->first);
  }
}

// final_map_line_sigmas_m change the chosen result's final calibration only: the same as the search's sigmas, the
// same result; larger on some matched lines, the same matches (the search is untouched), those lines weighed less
// in the final fit and its reported uncertainty larger.
TEST(LineMatcher, FinalSigmasWeighOnlyTheFinalCalibration)
{
  std::mt19937 rng(41);
  const std::vector<ic::Segment3d> room = makeRoom(rng);
  const ic::CameraModel truth = randomCamera(800, 1000, rng);
  const auto image = imageLines(truth, room, 0.3, 0, rng);
  ic::CameraModel start = truth;  // a camera close to the truth: matchAndCalibrateFrom, no prior search
  start.intrinsics().fx *= 1.01;
  start.intrinsics().fy *= 1.01;
  const std::vector<double> sigmas(room.size(), 0.001);
  const auto plain = ic::matchAndCalibrateFrom(room, image, start, kWidth, kHeight, {}, sigmas);
  ASSERT_TRUE(plain) << plain.error().describe();
  const auto same = ic::matchAndCalibrateFrom(room, image, start, kWidth, kHeight, {}, sigmas, {}, sigmas);
  ASSERT_TRUE(same);
  EXPECT_EQ(same->calibration.camera.intrinsics().fx, plain->calibration.camera.intrinsics().fx);
  EXPECT_EQ(same->calibration.camera.pose().translation, plain->calibration.camera.pose().translation);

  std::vector<double> final_sigmas = sigmas;  // every other matched map line 2 cm uncertain
  for (size_t k = 0; k < plain->candidate_matches.size(); k += 2)
    final_sigmas[plain->candidate_matches[k].map_line] = 0.02;
  const auto weighed = ic::matchAndCalibrateFrom(room, image, start, kWidth, kHeight, {}, sigmas, {}, final_sigmas);
  ASSERT_TRUE(weighed);
  ASSERT_EQ(weighed->candidate_matches.size(), plain->candidate_matches.size());
  for (size_t k = 0; k < plain->candidate_matches.size(); ++k)
  {
    EXPECT_EQ(weighed->candidate_matches[k].image_line, plain->candidate_matches[k].image_line);
    EXPECT_EQ(weighed->candidate_matches[k].map_line, plain->candidate_matches[k].map_line);
    EXPECT_EQ(weighed->correspondences.lines[k].image, image[weighed->candidate_matches[k].image_line]);
    EXPECT_EQ(weighed->correspondences.lines[k].world_sigma_m, final_sigmas[plain->candidate_matches[k].map_line]);
  }
  ASSERT_TRUE(plain->calibration.uncertainty.available && weighed->calibration.uncertainty.available);
  EXPECT_GT(weighed->calibration.uncertainty.position_m, 1.2 * plain->calibration.uncertainty.position_m);
  EXPECT_LT(ic::compareCameras(truth, weighed->calibration.camera).center_m, 0.03);
}

// The survey's calibration takes pixels as square by default: one focal length (fx = fy exactly), close to the
// truth's. A camera whose stream is resampled to non-square pixels (fy 4 % above fx, as an analogue camera's
// digitiser) is fitted by fx and fy apart with refinement.single_focal false. (One room: a matching takes 45 s.)
TEST(LineMatcher, SquarePixelsByDefaultAndApartWhenAsked)
{
  std::mt19937 rng(70);
  const std::vector<ic::Segment3d> room = makeRoom(rng);
  ic::CameraModel truth = randomCamera(800, 1000, rng);
  const auto image = imageLines(truth, room, 0.3, 0, rng);
  const ic::CameraPrior prior = offPrior(truth, 0.5, 10.0, 1.1, rng);
  const ic::LineMatcherOptions square;
  ASSERT_TRUE(square.calibration.refinement.single_focal);
  const auto result = ic::matchAndCalibrate(room, image, prior, kWidth, kHeight, square);
  ASSERT_TRUE(result) << result.error().describe();
  const ic::Intrinsics& k = result->calibration.camera.intrinsics();
  EXPECT_EQ(k.fx, k.fy);
  EXPECT_LT(std::abs(ic::compareCameras(truth, result->calibration.camera).focal_relative), 0.01);

  truth.intrinsics().fy *= 1.04;
  const auto non_square_image = imageLines(truth, room, 0.3, 0, rng);
  ic::LineMatcherOptions apart;
  apart.calibration.refinement.single_focal = false;
  const auto non_square = ic::matchAndCalibrate(room, non_square_image, prior, kWidth, kHeight, apart);
  ASSERT_TRUE(non_square) << non_square.error().describe();
  const ic::Intrinsics& n = non_square->calibration.camera.intrinsics();
  EXPECT_NEAR(n.fy / n.fx, 1.04, 0.01);  // as well as this room determines fx (ConvergesFromAnOffPrior: 1 %)
  EXPECT_LT(std::abs(ic::compareCameras(truth, non_square->calibration.camera).focal_relative), 0.01);
}
