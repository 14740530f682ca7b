#include <gtest/gtest.h>

#include <random>

#include "insitu_calibration/calibration.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/solvers/dlt.h"
#include "insitu_calibration/solvers/generalized_eigen.h"
#include "insitu_calibration/test_support/synthetic_lines.h"
#include "insitu_calibration/test_support/test_helpers.h"

namespace ic = insitu_calibration;

namespace
{
constexpr int kWidth = 1280;
constexpr int kHeight = 960;

struct Scene
{
  ic::CameraModel camera;
  ic::CorrespondenceSet data;
  std::vector<ic::Segment3d> segments;
};

Scene makeScene(unsigned seed, double corner_px, int lines, double noise_px, int image_points = 5, int world_points = 3)
{
  std::mt19937 rng(seed);
  ic::SyntheticCameraOptions camera_options;
  camera_options.corner_displacement_px = corner_px;
  Scene s;
  s.camera = ic::randomCamera(camera_options, rng);
  ic::SyntheticLineOptions line_options;
  line_options.lines = lines;
  line_options.image_noise_px = noise_px;
  line_options.image_points_per_line = image_points;
  line_options.world_points_per_line = world_points;
  ic::SyntheticLines synthetic = ic::makeSyntheticLines(s.camera, kWidth, kHeight, line_options, rng);
  s.data = synthetic.data;
  s.segments = synthetic.segments;
  s.data.points = ic::endPointCorrespondences(s.camera, s.segments, noise_px, rng);
  return s;
}

double cornerRadius(const ic::CameraModel& camera)
{
  return (camera.distortion().center - Eigen::Vector2d(0, 0)).norm() + 100.0;
}

struct Variant
{
  ic::DltMethod method;
  bool distortion;
  bool normalize;
  bool fixed_center;  // the true distortion centre given; otherwise the principal-point iteration finds it
};

std::string name(const Variant& v)
{
  return std::string(ic::toString(v.method)) + (v.distortion ? "+distortion" : "") +
         (v.normalize ? "" : " unnormalised") + (v.fixed_center ? " (centre given)" : " (centre iterated)");
}
}  // namespace

// Noise-free data: every variant recovers P and lambda to 1e-8 relative, for lambda = 0 and lambda != 0. The one
// exception is the unnormalised system with distortion: pixel coordinates squared (s^2 ~ 1e6 px^2) beside ones make
// it so ill-conditioned that double precision gives about 1e-5; that loss is what normalisation exists to avoid, and
// the variant is kept only to measure it.
TEST(Dlt, NoiseFreeRecoversTheCameraExactly)
{
  const std::vector<Variant> variants = {
      {ic::DltMethod::kLines, false, true, true},    {ic::DltMethod::kPoints, false, true, true},
      {ic::DltMethod::kCombined, false, true, true}, {ic::DltMethod::kLines, false, false, true},
      {ic::DltMethod::kPoints, false, false, true},  {ic::DltMethod::kLines, true, true, true},
      {ic::DltMethod::kPoints, true, true, true},    {ic::DltMethod::kCombined, true, true, true},
      {ic::DltMethod::kLines, true, false, true},    {ic::DltMethod::kPoints, true, false, true},
      {ic::DltMethod::kLines, true, true, false},    {ic::DltMethod::kCombined, true, true, false},
  };
  for (const Variant& v : variants)
  {
    for (unsigned seed = 1; seed <= 8; ++seed)
    {
      // lambda = 0 for the pin-hole variants; with distortion both lambda = 0 and a strong barrel.
      for (double corner_px : v.distortion ? std::vector<double>{0.0, -25.0, 12.0} : std::vector<double>{0.0})
      {
        const Scene s = makeScene(seed, corner_px, 30, 0.0);
        ic::DltOptions options;
        options.method = v.method;
        options.estimate_distortion = v.distortion;
        options.normalize = v.normalize;
        if (v.fixed_center)
          options.distortion_center = s.camera.distortion().center;
        const auto result = ic::solveDlt(s.data, options);
        ASSERT_TRUE(result) << name(v) << " seed " << seed << ": " << result.error().describe();
        const double tolerance = v.distortion && !v.normalize ? 1e-4 : 1e-8;
        EXPECT_LT(ic::test::projectionDifference(result->projection, s.camera.projectionMatrix()), tolerance)
            << name(v) << " seed " << seed << " corner " << corner_px;
        if (v.distortion)
        {
          EXPECT_LT(ic::test::lambdaDifference(result->camera.distortion().lambda, s.camera.distortion().lambda,
                                               cornerRadius(s.camera)),
                    tolerance)
              << name(v) << " seed " << seed << " lambda " << result->camera.distortion().lambda << " truth "
              << s.camera.distortion().lambda;
        }
        if (!v.fixed_center && v.distortion)
        {
          EXPECT_TRUE(result->center_converged) << name(v);
        }
      }
    }
  }
}

TEST(Dlt, PrincipalPointIterationConvergesFromTheImageCentre)
{
  const Scene s = makeScene(11, -30.0, 40, 0.0);
  ic::DltOptions options;
  options.method = ic::DltMethod::kLines;
  options.estimate_distortion = true;
  const auto result = ic::solveDlt(s.data, options);
  ASSERT_TRUE(result) << result.error().describe();
  EXPECT_TRUE(result->center_converged);
  EXPECT_GT(result->center_iterations, 1);
  // The iteration moved the centre from the image centre to the true principal point.
  EXPECT_GT((s.data.imageCenter() - s.camera.distortion().center).norm(), 1.0);
  EXPECT_LT((result->camera.distortion().center - s.camera.distortion().center).norm(), 1e-5);
}

// Noisy data: errors stay near the noise level and shrink as the number of lines grows.
TEST(Dlt, NoisyErrorsShrinkWithMoreLines)
{
  const double noise = 0.5;
  std::vector<double> focal_errors;
  for (int lines : {10, 40, 160})
  {
    double sum = 0.0;
    const int trials = 20;
    for (int t = 0; t < trials; ++t)
    {
      const Scene s = makeScene(100 + t, -15.0, lines, noise);
      ic::CalibrationOptions options;
      options.method = ic::DltMethod::kLines;
      options.distortion = ic::DistortionMode::kOn;
      const auto result = ic::calibrateCamera(s.data, options);
      ASSERT_TRUE(result) << result.error().describe();
      sum += std::abs(ic::relativeFocalError(s.camera.intrinsics(), result->camera.intrinsics()));
      // The algebraic fit leaves residuals at the noise level, not far above it.
      EXPECT_LT(result->reprojection.rms_px, 3.0 * noise) << lines << " lines, trial " << t;
    }
    focal_errors.push_back(sum / trials);
  }
  EXPECT_LT(focal_errors[1], focal_errors[0]);
  EXPECT_LT(focal_errors[2], focal_errors[1]);
  EXPECT_LT(focal_errors[2], 0.01);
}

// Hartley normalisation makes the point DLT more accurate under noise (the paper's Fig. 2).
TEST(Dlt, NormalisedBeatsUnnormalised)
{
  double normalized = 0.0;
  double raw = 0.0;
  for (int t = 0; t < 30; ++t)
  {
    const Scene s = makeScene(300 + t, 0.0, 20, 1.0);
    for (bool normalize : {true, false})
    {
      ic::DltOptions options;
      options.method = ic::DltMethod::kPoints;
      options.normalize = normalize;
      const auto result = ic::solveDlt(s.data, options);
      ASSERT_TRUE(result) << result.error().describe();
      const double e = std::abs(ic::relativeFocalError(s.camera.intrinsics(), result->camera.intrinsics()));
      (normalize ? normalized : raw) += e;
    }
  }
  EXPECT_LT(normalized, raw);
}

// ---------------------------------------------------------------------------------------------------------------
// Bad input: each gets its typed error.
namespace
{
ic::ErrorCode errorOf(const ic::CorrespondenceSet& data, ic::DltMethod method = ic::DltMethod::kLines,
                      bool distortion = false)
{
  ic::DltOptions options;
  options.method = method;
  options.estimate_distortion = distortion;
  const auto r = ic::solveDlt(data, options);
  EXPECT_FALSE(r) << "expected an error";
  return r ? ic::ErrorCode::kNoSolution : r.error().code();
}

ic::CorrespondenceSet linesThroughWorld(const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>& segments)
{
  // Images from a fixed camera, so only the 3D configuration is at fault.
  std::mt19937 rng(1);
  const ic::CameraModel camera = ic::randomCamera({}, rng);
  ic::CorrespondenceSet data;
  data.image_width = kWidth;
  data.image_height = kHeight;
  for (const auto& [a, b] : segments)
  {
    ic::LineCorrespondence line;
    line.world = {a, b};
    line.image = {*camera.projectUndistorted(a), *camera.projectUndistorted(b)};
    data.lines.push_back(line);
  }
  return data;
}

Eigen::Vector3d inFront(double x, double y, double z)
{
  // Points in the room the random camera looks into.
  return Eigen::Vector3d(2.0 + x, 2.0 + y, z);
}
}  // namespace

TEST(DltBadInput, TooFewLines)
{
  Scene s = makeScene(1, 0.0, 5, 0.0, 2, 2);
  s.data.points.clear();
  EXPECT_EQ(errorOf(s.data), ic::ErrorCode::kNotEnoughData);
}

TEST(DltBadInput, TooFewEquations)
{
  // Six lines with one world point each give six equations; eleven are needed.
  Scene s = makeScene(2, 0.0, 8, 0.0, 2, 1);
  s.data.points.clear();
  EXPECT_EQ(errorOf(s.data), ic::ErrorCode::kNotEnoughData);
}

TEST(DltBadInput, DistortionWithStraightLinesOnly)
{
  Scene s = makeScene(3, -10.0, 30, 0.0, 2, 2);
  s.data.points.clear();
  EXPECT_EQ(errorOf(s.data, ic::DltMethod::kLines, true), ic::ErrorCode::kNotEnoughData);
}

TEST(DltBadInput, NanAndInfinity)
{
  Scene s = makeScene(4, 0.0, 20, 0.0);
  s.data.lines[3].world[0].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(errorOf(s.data), ic::ErrorCode::kInvalidInput);
  s = makeScene(4, 0.0, 20, 0.0);
  s.data.lines[2].image[1].y() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(errorOf(s.data), ic::ErrorCode::kInvalidInput);
  s = makeScene(4, 0.0, 20, 0.0);
  s.data.points[0].image.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(errorOf(s.data, ic::DltMethod::kPoints), ic::ErrorCode::kInvalidInput);
}

TEST(DltBadInput, CoplanarPoints)
{
  std::mt19937 rng(9);
  const ic::CameraModel camera = ic::randomCamera({}, rng);
  ic::CorrespondenceSet data;
  data.image_width = kWidth;
  data.image_height = kHeight;
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 20; ++i)
  {
    const Eigen::Vector3d x = inFront(u(rng), u(rng), 0.0);  // all on the floor
    data.points.push_back({*camera.projectUndistorted(x), x});
  }
  EXPECT_EQ(errorOf(data, ic::DltMethod::kPoints), ic::ErrorCode::kDegenerate);
}

TEST(DltBadInput, CoplanarLines)
{
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> segments;
  for (int i = 0; i < 10; ++i)
    segments.push_back({inFront(0.1 * i, 0.0, 0.0), inFront(0.5, 1.0 + 0.07 * i, 0.0)});
  EXPECT_EQ(errorOf(linesThroughWorld(segments)), ic::ErrorCode::kDegenerate);
}

TEST(DltBadInput, ParallelLines)
{
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> segments;
  for (int i = 0; i < 10; ++i)
  {
    const Eigen::Vector3d a = inFront(0.3 * i, 0.2 * (i % 3), 0.1 * (i % 4));
    segments.push_back({a, a + Eigen::Vector3d(0, 0, 1)});
  }
  EXPECT_EQ(errorOf(linesThroughWorld(segments)), ic::ErrorCode::kDegenerate);
}

TEST(DltBadInput, LinesThroughOnePoint)
{
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> segments;
  const Eigen::Vector3d apex = inFront(0.5, 0.5, 1.0);
  std::mt19937 rng(2);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int i = 0; i < 10; ++i)
  {
    const Eigen::Vector3d d = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
    segments.push_back({apex + 0.3 * d, apex + 1.2 * d});
  }
  EXPECT_EQ(errorOf(linesThroughWorld(segments)), ic::ErrorCode::kDegenerate);
}

TEST(DltBadInput, MalformedLines)
{
  Scene s = makeScene(5, 0.0, 20, 0.0);
  s.data.lines[0].image.resize(1);
  EXPECT_EQ(errorOf(s.data), ic::ErrorCode::kInvalidInput);
  s = makeScene(5, 0.0, 20, 0.0);
  s.data.lines[0].world.clear();
  EXPECT_EQ(errorOf(s.data), ic::ErrorCode::kInvalidInput);
  s = makeScene(5, 0.0, 20, 0.0);
  s.data.lines[0].image[1] = s.data.lines[0].image[0];
  EXPECT_EQ(errorOf(s.data), ic::ErrorCode::kInvalidInput);
  s = makeScene(5, 0.0, 20, 0.0);
  s.data.image_width = 0;
  EXPECT_EQ(errorOf(s.data), ic::ErrorCode::kInvalidInput);
}

TEST(DltBadInput, MethodWithoutItsData)
{
  Scene s = makeScene(6, 0.0, 20, 0.0);
  s.data.points.clear();
  EXPECT_EQ(errorOf(s.data, ic::DltMethod::kPoints), ic::ErrorCode::kNotEnoughData);
}

TEST(DltBadInput, EigenproblemWithoutFiniteSolution)
{
  // C12 = 0: every eigenvalue of C11 p = mu C12 p is infinite, and C11 is regular (no exact pin-hole fit).
  ic::DltSystem system;
  const Eigen::Matrix4d scatter = Eigen::Matrix4d::Identity();
  system.addGroup(scatter, Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Identity(), 12);
  const auto solved = ic::solveDltSystem(system, true);
  ASSERT_FALSE(solved);
  EXPECT_EQ(solved.error().code(), ic::ErrorCode::kNoSolution);
  EXPECT_NE(solved.error().message().find("no real finite solution"), std::string::npos);
}

TEST(Calibration, AutoDistortionSaysWhy)
{
  Scene curved = makeScene(7, -15.0, 30, 0.2, 5);
  curved.data.points.clear();
  const auto a = ic::calibrateCamera(curved.data);
  ASSERT_TRUE(a) << a.error().describe();
  EXPECT_TRUE(a->distortion_estimated);
  EXPECT_LT(std::abs(ic::relativeFocalError(curved.camera.intrinsics(), a->camera.intrinsics())), 0.01);

  Scene straight = makeScene(7, 0.0, 30, 0.2, 2);
  straight.data.points.clear();
  const auto b = ic::calibrateCamera(straight.data);
  ASSERT_TRUE(b) << b.error().describe();
  EXPECT_FALSE(b->distortion_estimated);
  EXPECT_NE(b->distortion_note.find("3 or more"), std::string::npos) << b->distortion_note;
}
