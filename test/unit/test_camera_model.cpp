#include <gtest/gtest.h>

#include <random>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/camera/plumb_bob.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/solvers/decomposition.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

namespace ic = insitu_calibration;

TEST(DivisionModel, DistortUndoesUndistort)
{
  for (double lambda : {-4e-7, -1e-7, 0.0, 1e-7})
  {
    const ic::DivisionModel d{lambda, Eigen::Vector2d(640.0, 480.0)};
    for (double x = 0; x < 1280; x += 97)
      for (double y = 0; y < 960; y += 83)
      {
        const Eigen::Vector2d m(x, y);
        const auto u = d.undistort(m);
        ASSERT_TRUE(u);
        const auto back = d.distort(*u);
        ASSERT_TRUE(back) << "lambda " << lambda;
        EXPECT_LT((*back - m).norm(), 1e-9);
      }
  }
}

TEST(DivisionModel, BarrelMovesUndistortedPointsOutwards)
{
  const ic::DivisionModel d{-2e-7, Eigen::Vector2d(640.0, 480.0)};
  const Eigen::Vector2d corner(0.0, 0.0);
  const auto u = d.undistort(corner);
  ASSERT_TRUE(u);
  EXPECT_GT((*u - d.center).norm(), (corner - d.center).norm());
  // Exactly: r_u = r_d / (1 + lambda r_d^2).
  const double rd = (corner - d.center).norm();
  EXPECT_NEAR((*u - d.center).norm(), rd / (1.0 - 2e-7 * rd * rd), 1e-9);
}

TEST(DivisionModel, PincushionHasALimitedDomain)
{
  const ic::DivisionModel d{1e-6, Eigen::Vector2d::Zero()};
  // r_u <= 1 / (2 sqrt(lambda)) = 500 px.
  EXPECT_TRUE(d.distort(Eigen::Vector2d(499.0, 0.0)));
  EXPECT_FALSE(d.distort(Eigen::Vector2d(501.0, 0.0)));
}

TEST(CameraModel, ProjectAndBackProjectAgree)
{
  std::mt19937 rng(3);
  const ic::CameraModel camera = ic::randomCamera({}, rng);
  const Eigen::Isometry3d world_from_camera = camera.pose().worldFromCamera();
  for (double x = 10; x < 1270; x += 150)
    for (double y = 10; y < 950; y += 150)
    {
      const auto ray = camera.backProject(Eigen::Vector2d(x, y));
      ASSERT_TRUE(ray);
      const Eigen::Vector3d world = world_from_camera * (*ray * 4.0);
      const auto m = camera.project(world);
      ASSERT_TRUE(m);
      EXPECT_LT((*m - Eigen::Vector2d(x, y)).norm(), 1e-8);
    }
  // Behind the camera: no projection.
  EXPECT_FALSE(camera.project(world_from_camera * Eigen::Vector3d(0, 0, -1)));
}

TEST(CameraModel, PoseConventionsAreRep103)
{
  // A camera at (1, 2, 3) looking along world +x: optical z = world x, optical x (right) = world -y, y (down) = -z.
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  world_from_camera.translation() = Eigen::Vector3d(1, 2, 3);
  const ic::CameraPose pose = ic::CameraPose::fromWorldFromCamera(world_from_camera);
  EXPECT_LT((pose.center() - Eigen::Vector3d(1, 2, 3)).norm(), 1e-12);
  const Eigen::Vector3d ahead = pose.rotation * Eigen::Vector3d(5, 2, 3) + pose.translation;
  EXPECT_NEAR(ahead.z(), 4.0, 1e-12);
  const Eigen::Vector3d left = pose.rotation * Eigen::Vector3d(5, 3, 3) + pose.translation;
  EXPECT_LT(left.x(), 0.0);  // world +y is to the camera's left
}

TEST(Decomposition, RecoversKRtAndFixesTheSign)
{
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial)
  {
    ic::CameraModel camera = ic::randomCamera({}, rng);
    camera.intrinsics().skew = 0.7;
    const ic::Matrix34d p = camera.projectionMatrix();
    for (double scale : {1.0, -3.5, 1e-4})
    {
      const auto d = ic::decomposeProjection(scale * p);
      ASSERT_TRUE(d) << d.error().describe();
      EXPECT_NEAR(d->intrinsics.fx, camera.intrinsics().fx, 1e-8 * camera.intrinsics().fx);
      EXPECT_NEAR(d->intrinsics.fy, camera.intrinsics().fy, 1e-8 * camera.intrinsics().fy);
      EXPECT_NEAR(d->intrinsics.skew, 0.7, 1e-7);
      EXPECT_NEAR(d->intrinsics.cx, camera.intrinsics().cx, 1e-7);
      EXPECT_NEAR(d->intrinsics.cy, camera.intrinsics().cy, 1e-7);
      EXPECT_NEAR(d->pose.rotation.determinant(), 1.0, 1e-12);
      EXPECT_LT(ic::rotationDistance(d->pose.rotation, camera.pose().rotation), 1e-10);
      EXPECT_LT((d->pose.center() - camera.pose().center()).norm(), 1e-9);
    }
  }
}

TEST(Decomposition, RefusesACameraBehindItsScene)
{
  std::mt19937 rng(6);
  const ic::CameraModel camera = ic::randomCamera({}, rng);
  const Eigen::Isometry3d world_from_camera = camera.pose().worldFromCamera();
  const std::vector<Eigen::Vector3d> behind = {world_from_camera * Eigen::Vector3d(0.1, 0, -3),
                                               world_from_camera * Eigen::Vector3d(0, 0.2, -4),
                                               world_from_camera * Eigen::Vector3d(0.3, 0, -2)};
  const auto d = ic::decomposeProjection(camera.projectionMatrix(), behind);
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().code(), ic::ErrorCode::kNoSolution);
  EXPECT_FALSE(ic::decomposeProjection(ic::Matrix34d::Zero()));
}

TEST(Metrics, RotationDistanceIsTheAngle)
{
  for (double angle : {1e-9, 1e-4, 0.3, 2.0, 3.1})
  {
    const Eigen::Matrix3d r = Eigen::AngleAxisd(angle, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    EXPECT_NEAR(ic::rotationDistance(Eigen::Matrix3d::Identity(), r), angle, 1e-12 + 1e-9 * angle);
  }
}

TEST(Metrics, DistanceToPolylineExtendsTheEnds)
{
  const std::vector<Eigen::Vector2d> line = {{0, 0}, {10, 0}};
  EXPECT_NEAR(ic::distanceToPolyline(Eigen::Vector2d(50, 3), line), 3.0, 1e-12);  // beyond the end: infinite line
  const std::vector<Eigen::Vector2d> bent = {{0, 0}, {10, 0}, {20, 10}};
  EXPECT_NEAR(ic::distanceToPolyline(Eigen::Vector2d(5, 2), bent), 2.0, 1e-12);
  EXPECT_NEAR(ic::distanceToPolyline(Eigen::Vector2d(-5, 1), bent), 1.0, 1e-12);
}

TEST(PlumbBob, ApproximatesTheDivisionModel)
{
  ic::Intrinsics k{900, 900, 0, 640, 480};
  const double lambda = ic::lambdaForCornerDisplacement(k.principalPoint(), 1280, 960, -15.0);
  const ic::PlumbBobFit fit = ic::fitPlumbBob(k, ic::DivisionModel{lambda, k.principalPoint()}, 1280, 960);
  EXPECT_LT(fit.coefficients[0], 0.0);  // barrel
  EXPECT_LT(fit.max_error_px, 0.5);
  const ic::PlumbBobFit none = ic::fitPlumbBob(k, ic::DivisionModel{0.0, k.principalPoint()}, 1280, 960);
  EXPECT_EQ(none.coefficients[0], 0.0);
}
