// The depth-to-RGB misregistration estimated from creases (lines/depth_registration.h), on synthetic depth images made
// as the simulator's misregisterDepth does: the depth pixel q reads the surface at RGB pixel q + s.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "insitu_calibration/lines/depth_registration.h"

namespace ic = insitu_calibration;

namespace
{
constexpr int kWidth = 640, kHeight = 480;

ic::RgbdCamera xtion()
{
  ic::RgbdCamera c;
  c.width = kWidth;
  c.height = kHeight;
  c.intrinsics.fx = c.intrinsics.fy = 570.0;
  c.intrinsics.cx = 319.5;
  c.intrinsics.cy = 239.5;
  return c;
}

// Two planes meeting along the image line through p0 with direction d (RGB pixels), 3 m away: inverse depth affine
// on each side, equal on the line. Or, with a jump, two planes 0.5 m apart (an occluding edge); or one plane (a line
// of texture).
enum class EdgeKind
{
  kCrease,
  kJump,
  kTexture
};

struct SyntheticEdge
{
  Eigen::Vector2d p0, d;
  EdgeKind kind = EdgeKind::kCrease;
};

double inverseDepth(const SyntheticEdge& e, const Eigen::Vector2d& rgb_pixel)
{
  const Eigen::Vector2d n(-e.d.y(), e.d.x());
  const double across = n.dot(rgb_pixel - e.p0), along = e.d.dot(rgb_pixel - e.p0);
  const double f0 = 1.0 / 3.0;
  const double shared = f0 * (1.0 + 0.001 * along + 0.003 * across);  // a plane seen obliquely
  if (across < 0.0 || e.kind == EdgeKind::kTexture)
    return shared;
  if (e.kind == EdgeKind::kJump)
    return 1.0 / (1.0 / shared + 0.5);
  return shared - f0 * 0.006 * across;  // the second plane, bent about the line (about 35 deg at 3 m)
}

// One frame: the depth image in metres (noise: relative sigma per metre of depth, mm rounding), a grey image with a
// blurred step at the RGB edge, and the segment as a detector would give it (moved across by edge_error_px).
struct Frame
{
  cv::Mat depth, grey;
  ic::Segment2d segment;
};

Frame render(const SyntheticEdge& e, const Eigen::Vector2d& s, double noise, double edge_error_px, std::mt19937& rng)
{
  Frame f;
  f.depth = cv::Mat(kHeight, kWidth, CV_32FC1);
  f.grey = cv::Mat(kHeight, kWidth, CV_8UC1);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const Eigen::Vector2d n(-e.d.y(), e.d.x());
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
    {
      const Eigen::Vector2d q(x, y);
      double z = 1.0 / inverseDepth(e, q + s);
      if (noise > 0.0)
        z = std::round((z + noise * z * z * gauss(rng)) * 1000.0) / 1000.0;
      f.depth.at<float>(y, x) = static_cast<float>(z);
      const double across = n.dot(q - e.p0);
      f.grey.at<uint8_t>(y, x) = static_cast<uint8_t>(std::lround(90.0 + 80.0 * 0.5 * std::erfc(-across / 1.0)));
    }
  f.segment.a = e.p0 - 90.0 * e.d + edge_error_px * n;
  f.segment.b = e.p0 + 90.0 * e.d + edge_error_px * n;
  return f;
}

// Creases of every direction at different places of the image, one per frame.
void addCreases(ic::DepthRegistrationEstimator& estimator, const Eigen::Vector2d& s, double noise, double edge_error_px,
                int frames, unsigned seed, double max_angle_deg = 180.0)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (int i = 0; i < frames; ++i)
  {
    const double angle = max_angle_deg * M_PI / 180.0 * (i + 0.5) / frames;
    const SyntheticEdge e{Eigen::Vector2d(320.0 + 120.0 * u(rng), 240.0 + 80.0 * u(rng)),
                          Eigen::Vector2d(std::cos(angle), std::sin(angle)), EdgeKind::kCrease};
    const Frame f = render(e, s, noise, edge_error_px * gauss(rng), rng);
    estimator.addFrame(f.depth, f.grey, xtion(), {f.segment});
  }
}

ic::DepthRegistrationEstimator survey(const Eigen::Vector2d& s, double noise, double edge_error_px, int frames,
                                      unsigned seed, double max_angle_deg = 180.0)
{
  ic::DepthRegistrationEstimator estimator;
  addCreases(estimator, s, noise, edge_error_px, frames, seed, max_angle_deg);
  return estimator;
}
}  // namespace

TEST(DepthRegistration, RecoversTheOffsetWithoutNoise)
{
  const Eigen::Vector2d s(0.7, -0.3);
  const auto estimate = survey(s, 0.0, 0.0, 24, 1).estimate();
  ASSERT_TRUE(estimate) << estimate.error().message();
  std::printf("noise-free: estimated (%.4f, %.4f) for (0.7, -0.3), sigma (%.3f, %.3f), %zu creases\n",
              estimate->offset_px.x(), estimate->offset_px.y(), estimate->sigma_px.x(), estimate->sigma_px.y(),
              estimate->creases);
  EXPECT_NEAR(estimate->offset_px.x(), s.x(), 0.01);
  EXPECT_NEAR(estimate->offset_px.y(), s.y(), 0.01);
  EXPECT_EQ(estimate->creases, 24u);
  EXPECT_EQ(estimate->frames, 24u);
}

TEST(DepthRegistration, WithNoiseWithinTwoSigma)
{
  // Depth noise as the Xtion's (sigma 2.85e-3 z^2, mm steps) and each RGB edge 0.2 px off across (its texture).
  for (const Eigen::Vector2d& s : {Eigen::Vector2d(0.6, 0.25), Eigen::Vector2d(-0.4, 0.8), Eigen::Vector2d(0.0, 0.0)})
  {
    const auto estimate = survey(s, 2.85e-3, 0.2, 40, 7).estimate();
    ASSERT_TRUE(estimate) << estimate.error().message();
    std::printf("noisy: estimated (%.3f, %.3f) for (%.2f, %.2f), sigma (%.3f, %.3f), %zu creases, scatter %.2f\n",
                estimate->offset_px.x(), estimate->offset_px.y(), s.x(), s.y(), estimate->sigma_px.x(),
                estimate->sigma_px.y(), estimate->creases, estimate->scatter);
    EXPECT_LE(std::abs(estimate->offset_px.x() - s.x()), 2.0 * estimate->sigma_px.x());
    EXPECT_LE(std::abs(estimate->offset_px.y() - s.y()), 2.0 * estimate->sigma_px.y());
    EXPECT_LT(estimate->sigma_px.maxCoeff(), 0.15);  // 40 creases of 0.3 px: about 0.07 per axis
  }
}

TEST(DepthRegistration, OnlyCreasesAreMeasured)
{
  std::mt19937 rng(3);
  const Eigen::Vector2d s(0.5, 0.5);
  for (const EdgeKind kind : {EdgeKind::kCrease, EdgeKind::kJump, EdgeKind::kTexture})
  {
    const SyntheticEdge e{Eigen::Vector2d(300.0, 200.0), Eigen::Vector2d(0.6, 0.8), kind};
    const Frame f = render(e, s, 0.0, 0.0, rng);
    const auto crease = ic::measureCrease(f.depth, f.grey, xtion(), f.segment);
    EXPECT_EQ(crease.has_value(), kind == EdgeKind::kCrease) << static_cast<int>(kind);
    if (crease)
    {
      EXPECT_NEAR(crease->offset_px, -crease->normal.dot(s), 1e-3);
    }
  }
}

TEST(DepthRegistration, RefusesWhatTheCreasesCannotDetermine)
{
  // Too few creases.
  const auto few = survey(Eigen::Vector2d(0.5, 0.0), 0.0, 0.0, 6, 2).estimate();
  ASSERT_FALSE(few);
  EXPECT_EQ(few.error().code(), ic::ErrorCode::kNotEnoughData);
  EXPECT_NE(few.error().message().find("6 creases"), std::string::npos) << few.error().message();
  // Creases of nearly one direction (within 4 deg): the offset along them is not determined.
  const auto parallel = survey(Eigen::Vector2d(0.5, 0.0), 2.85e-3, 0.2, 20, 4, 4.0).estimate();
  ASSERT_FALSE(parallel);
  EXPECT_EQ(parallel.error().code(), ic::ErrorCode::kDegenerate) << parallel.error().message();
}

TEST(DepthRegistration, ReestimatesOnlyWhenTheCreasesHaveGrown)
{
  // The node asks at every keyframe; the estimator solves again only after the creases grew by a quarter.
  const Eigen::Vector2d s(0.4, -0.6);
  ic::DepthRegistrationEstimator estimator;
  EXPECT_FALSE(estimator.estimateWhenGrown()) << "no crease yet";
  addCreases(estimator, s, 0.0, 0.0, 12, 5);
  const auto first = estimator.estimateWhenGrown();
  ASSERT_TRUE(first && *first);
  EXPECT_EQ((**first).creases, 12u);
  EXPECT_NEAR((**first).offset_px.x(), s.x(), 0.01);
  EXPECT_NEAR((**first).offset_px.y(), s.y(), 0.01);
  EXPECT_FALSE(estimator.estimateWhenGrown()) << "nothing new";
  addCreases(estimator, s, 0.0, 0.0, 2, 6);  // 14 < 1.25 * 12
  EXPECT_FALSE(estimator.estimateWhenGrown());
  addCreases(estimator, s, 0.0, 0.0, 1, 7);  // 15 = 1.25 * 12
  const auto second = estimator.estimateWhenGrown();
  ASSERT_TRUE(second && *second);
  EXPECT_EQ((**second).creases, 15u);
  EXPECT_NEAR((**second).offset_px.x(), s.x(), 0.01);
  // A refused estimate (too few creases) is due too: the node logs nothing then, and asks again later.
  ic::DepthRegistrationEstimator few;
  addCreases(few, s, 0.0, 0.0, 4, 8);
  const auto refused = few.estimateWhenGrown();
  ASSERT_TRUE(refused);
  EXPECT_FALSE(*refused);
  EXPECT_EQ(refused->error().code(), ic::ErrorCode::kNotEnoughData);
}

TEST(DepthRegistration, DiscrepancyIsTheMahalanobisDistance)
{
  ic::DepthRegistrationEstimate e;
  e.offset_px = Eigen::Vector2d(0.6, -0.2);
  e.covariance = Eigen::Vector2d(0.1 * 0.1, 0.2 * 0.2).asDiagonal();
  e.sigma_px = Eigen::Vector2d(0.1, 0.2);
  EXPECT_DOUBLE_EQ(ic::registrationDiscrepancySigmas(e, e.offset_px), 0.0);
  // 0.3 px off along x is 3 sigma there, along y 1.5 sigma; both: their hypot.
  EXPECT_NEAR(ic::registrationDiscrepancySigmas(e, Eigen::Vector2d(0.9, -0.2)), 3.0, 1e-12);
  EXPECT_NEAR(ic::registrationDiscrepancySigmas(e, Eigen::Vector2d(0.6, 0.1)), 1.5, 1e-12);
  EXPECT_NEAR(ic::registrationDiscrepancySigmas(e, Eigen::Vector2d(0.9, 0.1)), std::hypot(3.0, 1.5), 1e-12);
  // Correlated: along the covariance's long axis a distance counts less than across it.
  e.covariance << 0.02, 0.018, 0.018, 0.02;
  const Eigen::Vector2d along = Eigen::Vector2d(1.0, 1.0).normalized() * 0.1;
  const Eigen::Vector2d across = Eigen::Vector2d(1.0, -1.0).normalized() * 0.1;
  EXPECT_NEAR(ic::registrationDiscrepancySigmas(e, e.offset_px + along), 0.1 / std::sqrt(0.038), 1e-9);
  EXPECT_NEAR(ic::registrationDiscrepancySigmas(e, e.offset_px + across), 0.1 / std::sqrt(0.002), 1e-9);
  // A singular covariance falls back to the larger sigma.
  e.covariance.setZero();
  e.sigma_px = Eigen::Vector2d(0.1, 0.25);
  EXPECT_NEAR(ic::registrationDiscrepancySigmas(e, e.offset_px + Eigen::Vector2d(0.5, 0.0)), 2.0, 1e-12);
}

TEST(DepthRegistration, AdvisesOnlyWhenTheOffsetInUseDisagrees)
{
  ic::DepthRegistrationEstimate e;
  e.offset_px = Eigen::Vector2d(0.62, -0.35);
  e.sigma_px = Eigen::Vector2d(0.12, 0.07);
  e.covariance = e.sigma_px.cwiseAbs2().asDiagonal();
  EXPECT_EQ(ic::registrationDisagreementAdvice(e, Eigen::Vector2d(0.6, -0.3)), "");
  const std::string advice = ic::registrationDisagreementAdvice(e, Eigen::Vector2d::Zero());
  EXPECT_NE(advice.find("0.620, -0.350 px"), std::string::npos) << advice;
  EXPECT_NE(advice.find("depth_registration/x_px, y_px"), std::string::npos) << advice;
  EXPECT_NE(advice.find("sigma_px to 0.120"), std::string::npos) << advice;
  // 0.3 px along x is 2.5 sigma: within 3, beyond 2.
  EXPECT_EQ(ic::registrationDisagreementAdvice(e, e.offset_px + Eigen::Vector2d(0.3, 0.0)), "");
  EXPECT_NE(ic::registrationDisagreementAdvice(e, e.offset_px + Eigen::Vector2d(0.3, 0.0), 2.0), "");
}
