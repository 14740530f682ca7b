#include <gtest/gtest.h>

#include <string>

#include "insitu_calibration/survey/fixed_camera.h"

namespace ic = insitu_calibration;

namespace
{
// A 30 deg camera's one-sigma uncertainty: focal length and position within the limits, rotation 0.9 deg, principal
// point (cx, cy) px.
ic::CameraUncertainty narrowView(double cx, double cy)
{
  ic::CameraUncertainty u;
  u.available = true;
  u.fx = 5.0;
  u.fy = 5.0;
  u.cx = cx;
  u.cy = cy;
  u.position_m = 0.015;
  u.rotation_deg = 0.9;
  return u;
}

bool namesThePrincipalPoint(const ic::Status& s)
{
  return !s &&
         s.error().message().find("principal_point and principal_point_sigma_px in its prior") != std::string::npos;
}
}  // namespace

// A weakly determined camera is refused; only when its rotation alone fails, and mostly through its principal point,
// does the refusal say that a known principal point would determine it (and not when the prior has one already).
TEST(FixedCameraChecks, ARotationLostToThePrincipalPointSaysWhatWouldFixIt)
{
  ic::Intrinsics k;
  k.fx = k.fy = 2390.0;
  k.cx = 660.0;
  k.cy = 470.0;
  const ic::FixedCameraOptions options;
  ic::CameraPrior prior;

  const ic::Status coupled = ic::checkDetermined(narrowView(30.0, 25.0), k, &prior, options);
  ASSERT_FALSE(coupled);
  EXPECT_EQ(coupled.error().code(), ic::ErrorCode::kDegenerate);
  EXPECT_EQ(coupled.error().message().rfind(ic::kWeaklyDeterminedRefusal, 0), 0u);
  EXPECT_TRUE(namesThePrincipalPoint(coupled)) << coupled.error().message();
  EXPECT_NE(coupled.error().message().find("39 px at 1 sigma, as much as a turn of 0.94 deg"), std::string::npos)
      << coupled.error().message();

  EXPECT_TRUE(namesThePrincipalPoint(ic::checkDetermined(narrowView(30.0, 25.0), k, nullptr, options)));
  prior.principal_point = Eigen::Vector2d(660.0, 470.0);
  const ic::Status known = ic::checkDetermined(narrowView(30.0, 25.0), k, &prior, options);
  EXPECT_FALSE(known);
  EXPECT_FALSE(namesThePrincipalPoint(known)) << "the prior knows it already";
  prior.principal_point.reset();

  const ic::Status not_coupled = ic::checkDetermined(narrowView(3.0, 2.0), k, &prior, options);
  EXPECT_FALSE(not_coupled);
  EXPECT_FALSE(namesThePrincipalPoint(not_coupled)) << "the principal point is not what leaves the rotation open";

  ic::CameraUncertainty far = narrowView(30.0, 25.0);
  far.position_m = 0.08;
  const ic::Status also_position = ic::checkDetermined(far, k, &prior, options);
  EXPECT_FALSE(also_position);
  EXPECT_FALSE(namesThePrincipalPoint(also_position)) << "a known principal point would not fix the position";

  ic::CameraUncertainty fine = narrowView(3.0, 2.0);
  fine.rotation_deg = 0.1;
  EXPECT_TRUE(ic::checkDetermined(fine, k, &prior, options));
  fine.available = false;
  fine.reason = "rank deficiency";
  EXPECT_FALSE(ic::checkDetermined(fine, k, &prior, options));
}
