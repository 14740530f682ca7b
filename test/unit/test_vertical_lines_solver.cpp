// The vertical-lines minimal solver (pose and focal length from two vertical and two other line correspondences):
// noise-free recovery from a minimal set over random cameras like installed ones, and degenerate input refused.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "insitu_calibration/solvers/vertical_lines_focal_pose.h"

namespace ic = insitu_calibration;

namespace
{
constexpr int kWidth = 1280;
constexpr int kHeight = 720;
constexpr double kDeg = M_PI / 180.0;

// A camera as installers mount them: any yaw, tilted down 10-60 deg, rolled up to 3 deg, 30-110 deg FOV.
ic::CameraModel randomCamera(std::mt19937& rng)
{
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double yaw = 2.0 * M_PI * u(rng), tilt = (10.0 + 50.0 * u(rng)) * kDeg, roll = (-3.0 + 6.0 * u(rng)) * kDeg;
  const double hfov = (30.0 + 80.0 * u(rng)) * kDeg;
  // Camera axes in the world: forward turned by yaw and pitched down by tilt; x right, y down.
  const Eigen::Vector3d forward(std::cos(yaw) * std::cos(tilt), std::sin(yaw) * std::cos(tilt), -std::sin(tilt));
  Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Vector3d down = forward.cross(right);
  right = Eigen::AngleAxisd(roll, forward) * right;
  down = Eigen::AngleAxisd(roll, forward) * down;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() << right, down, forward;
  world_from_camera.translation() = Eigen::Vector3d(10.0 * u(rng), 10.0 * u(rng), 2.4 + 2.6 * u(rng));
  ic::Intrinsics in;
  in.fx = in.fy = 0.5 * kWidth / std::tan(0.5 * hfov);
  in.cx = 0.5 * (kWidth - 1);
  in.cy = 0.5 * (kHeight - 1);
  return ic::CameraModel(in, ic::DivisionModel{0.0, in.principalPoint()},
                         ic::CameraPose::fromWorldFromCamera(world_from_camera));
}

// A 3D line of the given direction through a point the camera sees 2-10 m away, and its image.
ic::ImageMapLine visibleLine(const ic::CameraModel& camera, const Eigen::Vector3d& direction, std::mt19937& rng)
{
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (;;)
  {
    const Eigen::Vector2d pixel(kWidth * u(rng), kHeight * u(rng));
    const double depth = 2.0 + 8.0 * u(rng);
    const Eigen::Vector3d ray((pixel.x() - camera.intrinsics().cx) / camera.intrinsics().fx,
                              (pixel.y() - camera.intrinsics().cy) / camera.intrinsics().fy, 1.0);
    const Eigen::Vector3d point = camera.pose().worldFromCamera() * (depth * ray);
    ic::ImageMapLine line;
    line.world.a = point - 0.7 * direction;
    line.world.b = point + 0.5 * direction;
    const auto a = camera.projectUndistorted(line.world.a);
    const auto b = camera.projectUndistorted(line.world.b);
    if (!a || !b || (*a - *b).norm() < 20.0)
      continue;
    line.image_a = *a;
    line.image_b = *b;
    return line;
  }
}

// A direction more than 15 deg from vertical; horizontal (most of a building's lines) when asked.
Eigen::Vector3d randomNonVertical(std::mt19937& rng, bool horizontal = false)
{
  std::normal_distribution<double> n(0.0, 1.0);
  for (;;)
  {
    const Eigen::Vector3d d = Eigen::Vector3d(n(rng), n(rng), horizontal ? 0.0 : 0.5 * n(rng)).normalized();
    if (std::abs(d.z()) < std::cos(15.0 * kDeg))
      return d;
  }
}

// Two vertical lines and two non-vertical ones at least 20 deg apart (parallel ones leave f weakly determined when
// the camera is barely tilted).
std::array<ic::ImageMapLine, 4> minimalSet(const ic::CameraModel& camera, std::mt19937& rng, bool horizontal = false)
{
  const Eigen::Vector3d d2 = randomNonVertical(rng, horizontal);
  Eigen::Vector3d d3 = randomNonVertical(rng, horizontal);
  while (std::abs(d2.dot(d3)) > std::cos(20.0 * kDeg))
    d3 = randomNonVertical(rng, horizontal);
  return {visibleLine(camera, Eigen::Vector3d::UnitZ(), rng), visibleLine(camera, Eigen::Vector3d::UnitZ(), rng),
          visibleLine(camera, d2, rng), visibleLine(camera, d3, rng)};
}

struct Errors
{
  double rotation_rad, position_m, focal_relative;
};

// The solution closest to the truth.
Errors bestSolution(const std::vector<ic::CameraModel>& solutions, const ic::CameraModel& truth)
{
  Errors best{1e9, 1e9, 1e9};
  for (const ic::CameraModel& s : solutions)
  {
    const double rotation = Eigen::AngleAxisd(s.pose().rotation * truth.pose().rotation.transpose()).angle();
    const double position = (s.pose().center() - truth.pose().center()).norm();
    const double focal = std::abs(s.intrinsics().fx / truth.intrinsics().fx - 1.0);
    if (rotation + position + focal < best.rotation_rad + best.position_m + best.focal_relative)
      best = {rotation, position, focal};
  }
  return best;
}
}  // namespace

TEST(VerticalLinesSolver, RecoversPoseAndFocalFromAMinimalSet)
{
  std::mt19937 rng(12);
  const Eigen::Vector2d pp(0.5 * (kWidth - 1), 0.5 * (kHeight - 1));
  constexpr int kTrials = 2000;
  int recovered = 0;
  size_t most_solutions = 0;
  double worst_rotation = 0.0, worst_position = 0.0, worst_focal = 0.0;
  for (int trial = 0; trial < kTrials; ++trial)
  {
    const ic::CameraModel truth = randomCamera(rng);
    const auto set = minimalSet(truth, rng, trial % 2 == 1);  // every other set: horizontal lines (a double root)
    const std::vector<ic::CameraModel> solutions = ic::solveVerticalLinesFocalPose(set, pp, kWidth);
    most_solutions = std::max(most_solutions, solutions.size());
    const Errors e = bestSolution(solutions, truth);
    if (e.rotation_rad < 1e-6 && e.position_m < 1e-6 && e.focal_relative < 1e-6)
      ++recovered;
    else
      std::printf("trial %d: %zu solutions, best rotation %.3g rad, position %.3g m, focal %.3g\n", trial,
                  solutions.size(), e.rotation_rad, e.position_m, e.focal_relative);
    if (!solutions.empty() && e.rotation_rad < 1e-3)
    {
      worst_rotation = std::max(worst_rotation, e.rotation_rad);
      worst_position = std::max(worst_position, e.position_m);
      worst_focal = std::max(worst_focal, e.focal_relative);
    }
  }
  std::printf("recovered %d of %d; worst rotation %.3g rad, position %.3g m, focal %.3g; at most %zu solutions\n",
              recovered, kTrials, worst_rotation, worst_position, worst_focal, most_solutions);
  // 1998 of 2000 today: the two misses are horizontal pairs whose equation in f touches zero so flatly that the
  // root is located to about 1 % only (then refused by the 1e-6 residual check, not returned wrong).
  EXPECT_GE(recovered, kTrials - 4);
  EXPECT_LE(most_solutions, 4u);
}

// A corridor's map has one dominant horizontal direction (the cross lines are short): the hypotheses then give both
// non-vertical lines that direction. For a tilted camera, their vanishing point and the vertical one fix f and the
// rotation (orthogonal vanishing points), and the four lines the position.
TEST(VerticalLinesSolver, RecoversPoseAndFocalFromTwoParallelHorizontalLines)
{
  std::mt19937 rng(14);
  const Eigen::Vector2d pp(0.5 * (kWidth - 1), 0.5 * (kHeight - 1));
  constexpr int kTrials = 1000;
  int recovered = 0;
  for (int trial = 0; trial < kTrials; ++trial)
  {
    const ic::CameraModel truth = randomCamera(rng);
    const Eigen::Vector3d along = randomNonVertical(rng, true);
    std::array<ic::ImageMapLine, 4> set = {visibleLine(truth, Eigen::Vector3d::UnitZ(), rng),
                                           visibleLine(truth, Eigen::Vector3d::UnitZ(), rng),
                                           visibleLine(truth, along, rng), visibleLine(truth, along, rng)};
    const Errors e = bestSolution(ic::solveVerticalLinesFocalPose(set, pp, kWidth), truth);
    bool rotation_focal = false;
    for (const ic::RotationFocal& rf : ic::solveVerticalLinesRotationFocal(set, pp, kWidth))
      rotation_focal |= Eigen::AngleAxisd(rf.rotation * truth.pose().rotation.transpose()).angle() < 1e-6 &&
                        std::abs(rf.focal_px / truth.intrinsics().fx - 1.0) < 1e-6;
    if (e.rotation_rad < 1e-6 && e.position_m < 1e-6 && e.focal_relative < 1e-6 && rotation_focal)
      ++recovered;
    else
      std::printf("parallel pair, trial %d: best rotation %.3g rad, position %.3g m, focal %.3g\n", trial,
                  e.rotation_rad, e.position_m, e.focal_relative);
  }
  // 998 of 1000 today; the two misses return no solution (nothing wrong).
  EXPECT_GE(recovered, kTrials - 4);
}

TEST(VerticalLinesSolver, RecoversPoseFromThreeLinesWithKnownFocal)
{
  std::mt19937 rng(13);
  const Eigen::Vector2d pp(0.5 * (kWidth - 1), 0.5 * (kHeight - 1));
  constexpr int kTrials = 1000;
  int recovered = 0;
  for (int trial = 0; trial < kTrials; ++trial)
  {
    const ic::CameraModel truth = randomCamera(rng);
    const auto set = minimalSet(truth, rng, trial % 2 == 1);
    const std::vector<ic::CameraModel> solutions =
        ic::solveVerticalLinesPose({set[0], set[1], set[2]}, pp, kWidth, truth.intrinsics().fx);
    EXPECT_LE(solutions.size(), 2u);
    const Errors e = bestSolution(solutions, truth);
    if (e.rotation_rad < 1e-6 && e.position_m < 1e-6 && e.focal_relative < 1e-12)
      ++recovered;
    else
      std::printf("known focal, trial %d: %zu solutions, best rotation %.3g rad, position %.3g m\n", trial,
                  solutions.size(), e.rotation_rad, e.position_m);
  }
  // 999 of 1000 today: the miss is 19 um off (its three planes nearly share a line: position poorly conditioned).
  EXPECT_GE(recovered, kTrials - 2);
}

TEST(VerticalLinesSolver, RefusesDegenerateInput)
{
  std::mt19937 rng(7);
  const Eigen::Vector2d pp(0.5 * (kWidth - 1), 0.5 * (kHeight - 1));
  for (int trial = 0; trial < 50; ++trial)
  {
    const ic::CameraModel camera = randomCamera(rng);
    const std::array<ic::ImageMapLine, 4> good = minimalSet(camera, rng);
    ASSERT_FALSE(ic::solveVerticalLinesFocalPose(good, pp, kWidth).empty());
    // "Vertical" lines that are not vertical (20 deg off).
    auto leaning = good;
    leaning[0] = visibleLine(camera, Eigen::Vector3d(std::sin(20 * kDeg), 0.0, std::cos(20 * kDeg)), rng);
    EXPECT_TRUE(ic::solveVerticalLinesFocalPose(leaning, pp, kWidth).empty());
    // A vertical line given as one of the non-vertical pair.
    auto vertical_third = good;
    vertical_third[2] = visibleLine(camera, Eigen::Vector3d::UnitZ(), rng);
    EXPECT_TRUE(ic::solveVerticalLinesFocalPose(vertical_third, pp, kWidth).empty());
    // The vertical pair on one image line (no vanishing point).
    auto same_vertical = good;
    same_vertical[1] = good[0];
    EXPECT_TRUE(ic::solveVerticalLinesFocalPose(same_vertical, pp, kWidth).empty());
    // The non-vertical pair on one line (the yaw's two equations are one).
    auto same_other = good;
    same_other[3] = good[2];
    EXPECT_TRUE(ic::solveVerticalLinesFocalPose(same_other, pp, kWidth).empty());
    // A camera that is not tilted sees the verticals parallel (vanishing point at infinity): two parallel horizontal
    // lines then leave f undetermined.
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const Eigen::Vector3d c = camera.pose().center();
    const double yaw = 2.0 * M_PI * u(rng);
    Eigen::Isometry3d level = Eigen::Isometry3d::Identity();
    const Eigen::Vector3d forward(std::cos(yaw), std::sin(yaw), 0.0);
    const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
    level.linear() << right, -Eigen::Vector3d::UnitZ(), forward;
    level.translation() = c;
    const ic::CameraModel flat(camera.intrinsics(), camera.distortion(), ic::CameraPose::fromWorldFromCamera(level));
    const double heading = 2.0 * M_PI * u(rng);
    const Eigen::Vector3d horizontal(std::cos(heading), std::sin(heading), 0.0);
    const std::array<ic::ImageMapLine, 4> parallel = {
        visibleLine(flat, Eigen::Vector3d::UnitZ(), rng), visibleLine(flat, Eigen::Vector3d::UnitZ(), rng),
        visibleLine(flat, horizontal, rng), visibleLine(flat, horizontal, rng)};
    EXPECT_TRUE(ic::solveVerticalLinesFocalPose(parallel, pp, kWidth).empty()) << "trial " << trial;
  }
}
