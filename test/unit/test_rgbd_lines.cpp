// 3D lines from RGB-D: RANSAC on points with outliers, depth on the near side of discontinuities, whole frames
// rendered with Xtion-like depth noise (16UC1 millimetres and 32FC1 metres), bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <iostream>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/lines/line_evaluation.h"
#include "insitu_calibration/lines/line_map.h"
#include "insitu_calibration/lines/rgbd_lines.h"
#include "insitu_calibration/test_support/line_scene.h"
#include "insitu_calibration/geometry/optical_frame.h"
#include "insitu_calibration/test_support/test_helpers.h"

namespace ic = insitu_calibration;

namespace
{
constexpr unsigned kSeed = 424242;
constexpr double kXtionNoisePerM = 1.425e-3;  // sigma_z = k z^2 (Khoshelham & Elberink 2012)

double median(std::vector<double> v)
{
  if (v.empty())
    return std::nan("");
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  return std::acos(std::min(1.0, std::abs(a.normalized().dot(b.normalized())))) * 180.0 / M_PI;
}

double distanceToLine(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  const Eigen::Vector3d d = (b - a).normalized();
  return ((p - a) - (p - a).dot(d) * d).norm();
}

ic::RgbdCamera xtionCamera()
{
  return ic::test::xtionRgbdCamera(570.3);
}

// The optical frame at position, looking at target (z forward, x right, y down; world z up).
Eigen::Isometry3d lookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = *ic::opticalRotationLookingAlong(target - position);
  t.translation() = position;
  return t;
}

ic::RgbdFrame renderFrame(const ic::LineScene& scene, const Eigen::Isometry3d& T_map_camera, bool millimetres,
                          std::mt19937& rng)
{
  ic::RgbdFrame f;
  f.camera = xtionCamera();
  f.T_map_camera = T_map_camera;
  const ic::CameraModel model(f.camera.intrinsics, ic::DivisionModel{0.0, f.camera.intrinsics.principalPoint()},
                              ic::CameraPose::fromWorldFromCamera(T_map_camera));
  ic::LineSceneRenderOptions render;
  render.supersampling = 4;
  render.noise_sigma = 2.0;
  render.blur_sigma_px = 0.5;
  cv::Mat grey = ic::renderGrey(scene, model, 640, 480, render, rng);
  cv::cvtColor(grey, f.rgb, cv::COLOR_GRAY2BGR);
  f.depth = ic::makeSensorDepth(ic::renderDepth(scene, model, 640, 480), kXtionNoisePerM, millimetres, rng);
  return f;
}

}  // namespace

TEST(Line3dFitter, RansacFindsTheLineAmongThirtyPercentOutliers)
{
  std::cout << "seed " << kSeed << std::endl;
  std::mt19937 rng(kSeed);
  const Eigen::Vector3d a(0.5, -0.3, 2.0), b(1.2, 0.4, 3.1);
  const Eigen::Vector3d d = (b - a).normalized();
  const Eigen::Vector3d n1 = d.unitOrthogonal(), n2 = d.cross(n1);
  std::normal_distribution<double> noise(0.0, 0.003);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial)
  {
    std::vector<Eigen::Vector3d> points;
    double u_min = 1.0, u_max = 0.0;
    for (int i = 0; i < 70; ++i)
    {
      const double u = unit(rng);
      u_min = std::min(u_min, u);
      u_max = std::max(u_max, u);
      points.push_back(a + u * (b - a) + noise(rng) * n1 + noise(rng) * n2);
    }
    // 30 % outliers in the box around the segment, at least 5 cm off the line.
    while (points.size() < 100)
    {
      const Eigen::Vector3d p(0.3 + unit(rng) * 1.1, -0.5 + unit(rng) * 1.1, 1.8 + unit(rng) * 1.5);
      if (distanceToLine(p, a, b) > 0.05)
        points.push_back(p);
    }
    std::shuffle(points.begin(), points.end(), rng);
    ic::Line3dFitOptions options;
    options.threshold_m = 0.01;
    options.threshold_per_m2 = 0.0;
    options.seed = kSeed + trial;
    const auto line = ic::fitLine3d(points, options);
    ASSERT_TRUE(line.ok()) << line.error().describe();
    EXPECT_GE(line->inliers, 68);
    EXPECT_LE(line->inliers, 72);  // an outlier may fall within 1 cm of the line by chance, not more
    EXPECT_LT(angleDeg(line->direction(), b - a), 0.5);
    EXPECT_LT(distanceToLine(line->a, a, b), 0.003);
    EXPECT_LT(distanceToLine(line->b, a, b), 0.003);
    // The extent is the inliers' (the ends of the line lie at the extreme inliers, up to their noise).
    const Eigen::Vector3d e0 = a + u_min * (b - a), e1 = a + u_max * (b - a);
    EXPECT_LT(std::min((line->a - e0).norm() + (line->b - e1).norm(), (line->a - e1).norm() + (line->b - e0).norm()),
              0.02);
    EXPECT_LT(line->rms_m, 0.006);
    // Deterministic for a seed.
    const auto again = ic::fitLine3d(points, options);
    ASSERT_TRUE(again.ok());
    EXPECT_EQ((again->a - line->a).norm(), 0.0);
  }
}

TEST(Line3dFitter, BadPointSetsGiveErrors)
{
  ic::Line3dFitOptions options;
  EXPECT_EQ(ic::fitLine3d({}, options).error().code(), ic::ErrorCode::kNotEnoughData);
  EXPECT_EQ(ic::fitLine3d({Eigen::Vector3d(1, 2, 3)}, options).error().code(), ic::ErrorCode::kNotEnoughData);
  std::vector<Eigen::Vector3d> nan(50, Eigen::Vector3d::Constant(std::nan("")));
  EXPECT_EQ(ic::fitLine3d(nan, options).error().code(), ic::ErrorCode::kNotEnoughData);
  // All points equal: no line (no throw, whatever PCL thinks of the samples).
  std::vector<Eigen::Vector3d> same(50, Eigen::Vector3d(1, 2, 3));
  EXPECT_FALSE(ic::fitLine3d(same, options).ok());
  // Too short.
  std::vector<Eigen::Vector3d> tiny;
  for (int i = 0; i < 50; ++i)
    tiny.push_back(Eigen::Vector3d(1, 2, 3) + Eigen::Vector3d(0.001 * i, 0, 0));
  EXPECT_EQ(ic::fitLine3d(tiny, options).error().code(), ic::ErrorCode::kDegenerate);
  ic::Line3dFitOptions bad;
  bad.probability = 1.5;
  EXPECT_EQ(ic::fitLine3d(tiny, bad).error().code(), ic::ErrorCode::kInvalidInput);
}

TEST(DepthSampler, TakesTheNearSideOfADiscontinuityAndTheEdgeDepthOnASlantedSurface)
{
  // Left of x = 100.5: a plane slanted in x (inverse depth affine in the image), 1.5 m at the edge and 1 cm deeper
  // per px there, like a wall seen at a grazing angle; right: the background at 3.2 m.
  cv::Mat depth(200, 200, CV_32FC1);
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x)
      depth.at<float>(y, x) = x <= 100 ? static_cast<float>(1.0 / (1.0 / 1.5 - 0.01 / 2.25 * (x - 100.5))) : 3.2f;
  ic::Segment2d edge{{100.5, 20.0}, {100.5, 180.0}};
  for (const bool flip : {false, true})
  {
    const ic::Segment2d s = flip ? ic::Segment2d{edge.b, edge.a} : edge;
    const auto samples = ic::sampleDepthAlongSegment(depth, s);
    ASSERT_GT(samples.size(), 70u);
    for (const auto& sample : samples)
    {
      EXPECT_NEAR(sample.depth_m, 1.5, 1e-4);
      EXPECT_TRUE(sample.discontinuity);
    }
  }
  // A crease (no discontinuity): two planes meeting at x = 100, both sloping away (a convex corner at 2 m).
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x)
      depth.at<float>(y, x) = static_cast<float>(1.0 / (0.5 - 0.001 * std::abs(x - 100.0)));
  const auto crease = ic::sampleDepthAlongSegment(depth, ic::Segment2d{{100.0, 20.0}, {100.0, 180.0}});
  ASSERT_GT(crease.size(), 70u);
  for (const auto& sample : crease)
  {
    EXPECT_NEAR(sample.depth_m, 2.0, 2e-4);
    EXPECT_FALSE(sample.discontinuity);
  }
}

// A chair back's top seen from above at a grazing angle: the wall at 2.10 m above the edge (y < 100.5), no return
// from the top face (5 px below the edge, more than the band read), then the chair's front face at 1.90 m. The only
// depth next to the edge is the wall's, the background: no sample may take it. With the front face farther than the
// wall (a projector shadow on the background instead), the readings are the near side and are kept.
TEST(DepthSampler, NoDepthFromTheBackgroundOfAnUnseenSurface)
{
  for (const bool shadow : {false, true})
  {
    cv::Mat depth(200, 200, CV_32FC1);
    for (int y = 0; y < 200; ++y)
      for (int x = 0; x < 200; ++x)
      {
        float z = 2.10f;  // wall
        if (y > 100 && y <= 105)
          z = std::numeric_limits<float>::quiet_NaN();  // no return
        else if (y > 105)
          z = shadow ? 2.60f : 1.90f;
        depth.at<float>(y, x) = z;
      }
    const auto samples = ic::sampleDepthAlongSegment(depth, ic::Segment2d{{20.0, 100.5}, {180.0, 100.5}});
    if (!shadow)
    {
      EXPECT_TRUE(samples.empty()) << samples.size() << " samples, the first at " << samples.front().depth_m << " m";
    }
    else
    {
      ASSERT_GT(samples.size(), 70u);
      for (const auto& sample : samples)
        EXPECT_NEAR(sample.depth_m, 2.10, 1e-4);
    }
    // Without the search beyond the gap, the wall was taken (the first version: 3 cm off at the chair backs).
    ic::DepthSamplerOptions no_search;
    no_search.gap_search_px = 0;
    EXPECT_GT(ic::sampleDepthAlongSegment(depth, ic::Segment2d{{20.0, 100.5}, {180.0, 100.5}}, no_search).size(), 70u);
  }
}

TEST(DepthSampler, FindsASmallStepOverTheWholeSegment)
{
  // A door frame 1 cm proud of its wall at 2 m (left of x = 100.5: 2.00 m, right: 2.01 m), below the per-sample
  // jump (3 cm), with the Xtion's noise (5.7 mm at 2 m) and without.
  std::mt19937 rng(kSeed);
  for (const double sigma_per_m : {0.0, kXtionNoisePerM})
  {
    cv::Mat truth(240, 200, CV_32FC1);
    for (int y = 0; y < 240; ++y)
      for (int x = 0; x < 200; ++x)
        truth.at<float>(y, x) = x <= 100 ? 2.0f : 2.01f;
    const cv::Mat depth = ic::makeSensorDepth(truth, sigma_per_m, false, rng);
    const auto samples = ic::sampleDepthAlongSegment(depth, ic::Segment2d{{100.5, 10.0}, {100.5, 230.0}});
    ASSERT_GT(samples.size(), 100u);
    double mean = 0.0;
    for (const auto& sample : samples)
      mean += sample.depth_m / samples.size();
    std::cout << "noise " << sigma_per_m << " /m: mean edge depth " << mean << " m" << std::endl;
    // The frame's depth: within the standard error of the mean of ~100 extrapolated samples.
    EXPECT_NEAR(mean, 2.0, sigma_per_m > 0.0 ? 0.0015 : 1e-6);
    if (sigma_per_m == 0.0)
    {
      for (const auto& sample : samples)
        EXPECT_NEAR(sample.depth_m, 2.0, 1e-6);
    }
  }
  // Without the step test the edge depth is halfway.
  ic::DepthSamplerOptions off;
  off.small_step_sigmas = 0.0;
  cv::Mat truth(240, 200, CV_32FC1);
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 200; ++x)
      truth.at<float>(y, x) = x <= 100 ? 2.0f : 2.01f;
  const auto halfway = ic::sampleDepthAlongSegment(truth, ic::Segment2d{{100.5, 10.0}, {100.5, 230.0}}, off);
  ASSERT_FALSE(halfway.empty());
  EXPECT_GT(halfway.front().depth_m, 2.002);
}

// A panel 3 mm proud of its wall at 2.5 m (left of a vertical edge), seen in 40 frames with the Xtion's depth noise
// (8.9 mm per reading there): one frame's step test cannot tell the step, so each frame's line lies between panel
// and wall. Pooled over the map line's observations (half of them with the segment reversed, so their sides are
// swapped) the step is clear and the map line lies on the panel. On a flat wall nothing is pooled into a step: the
// map line is the same with the pooling on or off.
TEST(RgbdLineMap, SmallStepPooledOverKeyframesPutsTheEdgeOnTheNearSide)
{
  std::mt19937 rng(kSeed);
  const ic::RgbdCamera camera = xtionCamera();
  for (const double step_m : {0.003, 0.0})
  {
    cv::Mat truth(480, 640, CV_32FC1);
    for (int y = 0; y < 480; ++y)
      for (int x = 0; x < 640; ++x)
        truth.at<float>(y, x) = static_cast<float>(x <= 320 ? 2.5 : 2.5 + step_m);
    ic::LineMapOptions on, off;
    on.depth_step_sigmas = 5.0;
    off.depth_step_sigmas = 0.0;
    ic::LineMap pooled(on), unpooled(off);
    int frames_telling = 0;
    for (int k = 0; k < 40; ++k)
    {
      const cv::Mat depth = ic::makeSensorDepth(truth, kXtionNoisePerM, false, rng);
      const ic::Segment2d up{{320.5, 420.0}, {320.5, 60.0}}, down{up.b, up.a};
      const ic::Segment2d& segment = k % 2 ? up : down;
      const auto samples = ic::sampleDepthAlongSegment(depth, segment);
      auto line = ic::fitLine3dToDepthSamples(segment, samples, camera, ic::Line3dFitOptions());
      ASSERT_TRUE(line) << line.error().message();
      line->stamp = k;
      const ic::DepthStep& s = line->depth_step;
      ASSERT_GT(s.samples, 100);
      frames_telling += std::abs(s.left_nearer_by_m) > 5.0 * s.sigma_m && std::abs(s.left_nearer_by_m) >= 0.004;
      pooled.insert(*line);
      unpooled.insert(*line);
    }
    ASSERT_EQ(pooled.size(), 1u);
    ASSERT_EQ(unpooled.size(), 1u);
    const double z_pooled = pooled.lines()[0].point.z(), z_unpooled = unpooled.lines()[0].point.z();
    std::cout << "step " << 1000.0 * step_m << " mm: " << frames_telling << " of 40 frames tell it; map line "
              << 1000.0 * (z_pooled - 2.5) << " mm behind the panel pooled, " << 1000.0 * (z_unpooled - 2.5)
              << " mm without" << std::endl;
    EXPECT_LT(frames_telling, 10);
    if (step_m > 0.0)
    {
      EXPECT_NEAR(z_pooled, 2.5, 0.0006);
      EXPECT_GT(z_unpooled - 2.5, 0.001);
    }
    else
    {
      EXPECT_EQ(z_pooled, z_unpooled);
    }
  }
}

// A near rectangle slanted like a wall seen at a grazing angle (1 cm deeper per px in x) before a background at 3.2 m,
// its depth image misregistered: the reading at pixel (x, y) is the scene at (x + 0.7, y - 0.4). Sampled with that
// offset, the contours' edge depth is the true one (at ten sub-pixel positions of the contour); without it the
// slant puts it millimetres off.
TEST(DepthSampler, RemovesTheDepthImagesMisregistration)
{
  auto inverse_depth = [](double x) { return 1.0 / 1.5 - 0.01 / 2.25 * (x - 100.0); };
  const Eigen::Vector2d truth_offset(0.7, -0.4);
  ic::DepthSamplerOptions registered;
  registered.registration_offset_px = truth_offset;
  double error_with = 0.0, top_error_with = 0.0, error_without = 0.0;
  size_t without_count = 0;
  for (int k = 0; k < 10; ++k)
  {
    const double lo = 60.05 + 0.1 * k, hi = 140.05 + 0.1 * k;
    cv::Mat depth(200, 200, CV_32FC1);
    for (int y = 0; y < 200; ++y)
      for (int x = 0; x < 200; ++x)
      {
        const double sx = x + truth_offset.x(), sy = y + truth_offset.y();
        const bool near = sx > lo && sx < hi && sy > lo && sy < hi;
        depth.at<float>(y, x) = static_cast<float>(near ? 1.0 / inverse_depth(sx) : 3.2);
      }
    // The left contour (x = lo, both directions): across it the slant, along it none, so every sample's depth is the
    // plane's at the edge. The top one (y = lo): the band's pixels are rounded along it, where the slant is, so only
    // its mean over the sub-pixel positions is exact.
    for (const auto& s : {ic::Segment2d{{lo, lo + 5}, {lo, hi - 5}}, ic::Segment2d{{lo, hi - 5}, {lo, lo + 5}},
                          ic::Segment2d{{lo + 5, lo}, {hi - 5, lo}}})
    {
      const bool top = s.a.y() == s.b.y();
      const auto with = ic::sampleDepthAlongSegment(depth, s, registered);
      ASSERT_GT(with.size(), 30u);
      for (const auto& sample : with)
      {
        const double error = sample.depth_m - 1.0 / inverse_depth(sample.pixel.x());
        if (top)
          top_error_with += error / with.size();
        else
          error_with = std::max(error_with, std::abs(error));
      }
      for (const auto& sample : ic::sampleDepthAlongSegment(depth, s))
      {
        error_without += std::abs(sample.depth_m - 1.0 / inverse_depth(sample.pixel.x()));
        ++without_count;
      }
    }
  }
  top_error_with /= 10.0;
  ASSERT_GT(without_count, 100u);
  error_without /= without_count;
  std::cout << "edge depth error: at most " << 1000.0 * error_with << " mm with the offset (top contour: mean "
            << 1000.0 * top_error_with << " mm), mean " << 1000.0 * error_without << " mm without" << std::endl;
  EXPECT_LT(error_with, 1e-3);
  EXPECT_LT(std::abs(top_error_with), 1e-3);
  EXPECT_GT(error_without, 3e-3);
}

TEST(DepthSampler, MillimetresAndMetresAgree)
{
  std::mt19937 rng(kSeed);
  cv::Mat truth(100, 120, CV_32FC1);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 120; ++x)
      truth.at<float>(y, x) = x < 60 ? 1.2f + 0.001f * y : 2.5f;
  const cv::Mat mm = ic::makeSensorDepth(truth, 0.0, true, rng);
  const cv::Mat m = ic::makeSensorDepth(truth, 0.0, false, rng);
  ASSERT_EQ(mm.type(), CV_16UC1);
  ASSERT_EQ(m.type(), CV_32FC1);
  const auto from_mm = ic::depthToMeters(mm);
  const auto from_m = ic::depthToMeters(m);
  ASSERT_TRUE(from_mm.ok());
  ASSERT_TRUE(from_m.ok());
  const ic::Segment2d s{{59.5, 10.0}, {59.5, 90.0}};
  const auto a = ic::sampleDepthAlongSegment(*from_mm, s);
  const auto b = ic::sampleDepthAlongSegment(*from_m, s);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_FALSE(a.empty());
  for (size_t i = 0; i < a.size(); ++i)
  {
    EXPECT_NEAR(a[i].depth_m, b[i].depth_m, 0.0006);  // millimetre quantisation
    EXPECT_NEAR(a[i].depth_m, 1.2 + 0.001 * a[i].pixel.y(), 0.001);
  }
  // Ranges: readings outside are no measurement.
  const auto near_only = ic::depthToMeters(m, 0.5, 2.0);
  ASSERT_TRUE(near_only.ok());
  EXPECT_TRUE(std::isnan(near_only->at<float>(50, 100)));
  EXPECT_FALSE(std::isnan(near_only->at<float>(50, 10)));
}

TEST(RgbdLines, RenderedFramesGiveLinesWithinACentimetreAndHalfADegree)
{
  std::cout << "seed " << kSeed << std::endl;
  std::mt19937 rng(kSeed);
  ic::LineScene scene = ic::makeRoomScene(rng);
  const std::vector<ic::Segment3d> truth = scene.edges();
  const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> views = {
      {{3.0, 2.8, 0.9}, {1.5, 0.0, 0.9}},  // door and box 1
      {{3.2, 2.0, 1.0}, {6.0, 2.4, 0.8}},  // door on x = 6
      {{2.5, 2.5, 0.8}, {2.8, 5.0, 1.2}},  // posters, skirting
      {{2.0, 3.0, 1.2}, {4.4, 3.6, 0.5}},  // box 2
  };
  std::vector<double> distance, angle, distance_pca, angle_pca;
  int lines_total = 0, matched_total = 0;
  for (const bool millimetres : {true, false})
  {
    for (const auto& [position, target] : views)
    {
      const ic::RgbdFrame frame = renderFrame(scene, lookAt(position, target), millimetres, rng);
      for (const auto refinement : {ic::Line3dRefinement::kInterpretationPlane, ic::Line3dRefinement::kPca})
      {
        ic::RgbdLineOptions options;
        options.fit.refinement = refinement;
        ic::RgbdLineStats stats;
        const auto lines = ic::extractRgbdLines(frame, options, &stats);
        ASSERT_TRUE(lines.ok()) << lines.error().describe();
        for (const auto& line : *lines)
        {
          if (line.range_m > 3.0)
            continue;
          const ic::Line3dError e = ic::measureLine3d(line.a, line.b, truth, 0.1, 5.0);
          const bool plane = refinement == ic::Line3dRefinement::kInterpretationPlane;
          if (plane)
            ++lines_total;
          if (e.edge < 0)
            continue;
          if (plane)
          {
            ++matched_total;
            distance.push_back(e.distance_m);
            angle.push_back(e.angle_deg);
          }
          else
          {
            distance_pca.push_back(e.distance_m);
            angle_pca.push_back(e.angle_deg);
          }
        }
        if (refinement == ic::Line3dRefinement::kInterpretationPlane)
          std::cout << (millimetres ? "16UC1" : "32FC1") << " view: " << stats.segments << " segments, " << stats.lines
                    << " lines (" << stats.no_depth << " no depth, " << stats.no_line << " no consensus, "
                    << stats.too_short << " too short)" << std::endl;
      }
    }
  }
  std::cout << "within 3 m: " << matched_total << " of " << lines_total << " lines on a true edge; median error "
            << median(distance) * 1000 << " mm, " << median(angle)
            << " deg (PCA refinement: " << median(distance_pca) * 1000 << " mm, " << median(angle_pca) << " deg)"
            << std::endl;
  ASSERT_GT(lines_total, 40);
  EXPECT_GT(matched_total, 0.9 * lines_total);
  EXPECT_LT(median(distance), 0.01);
  EXPECT_LT(median(angle), 0.5);
}

TEST(RgbdLines, BadInputGivesTypedErrors)
{
  std::mt19937 rng(kSeed);
  ic::LineScene scene = ic::makeRoomScene(rng);
  const ic::RgbdFrame good = renderFrame(scene, lookAt({3.0, 2.8, 0.9}, {1.5, 0.0, 0.9}), true, rng);
  ic::RgbdLineExtractor extractor;
  {
    auto lines = extractor.extract(good);
    ASSERT_TRUE(lines.ok()) << lines.error().describe();
    EXPECT_FALSE(lines->empty());
  }
  auto expectError = [&](const ic::RgbdFrame& f, ic::ErrorCode code, const std::string& what) {
    ic::RgbdLineStats stats;
    auto r = extractor.extract(f, &stats);
    ASSERT_FALSE(r.ok()) << what;
    EXPECT_EQ(r.error().code(), code) << what << ": " << r.error().describe();
    std::cout << what << " -> " << r.error().describe() << std::endl;
  };
  ic::RgbdFrame f = good;
  f.rgb = cv::Mat();
  expectError(f, ic::ErrorCode::kInvalidInput, "empty RGB");
  f = good;
  f.depth = cv::Mat();
  expectError(f, ic::ErrorCode::kInvalidInput, "empty depth");
  f = good;
  f.depth = cv::Mat(480, 640, CV_16UC1, cv::Scalar(0));
  expectError(f, ic::ErrorCode::kNotEnoughData, "all-zero depth");
  f = good;
  f.depth = cv::Mat(480, 640, CV_32FC1, cv::Scalar(std::nan("")));
  expectError(f, ic::ErrorCode::kNotEnoughData, "all-NaN depth");
  f = good;
  f.depth = cv::Mat(480, 640, CV_8UC1, cv::Scalar(1));
  expectError(f, ic::ErrorCode::kInvalidInput, "8-bit depth");
  f = good;
  f.camera.intrinsics.fx = 0.0;
  expectError(f, ic::ErrorCode::kInvalidInput, "zero focal length");
  f = good;
  cv::resize(good.depth, f.depth, cv::Size(320, 240), 0, 0, cv::INTER_NEAREST);
  expectError(f, ic::ErrorCode::kInvalidInput, "depth size mismatch");
  f = good;
  f.camera.width = 1280;
  f.camera.height = 960;
  expectError(f, ic::ErrorCode::kInvalidInput, "camera_info size mismatch");
  f = good;
  f.T_map_camera.translation().x() = std::nan("");
  expectError(f, ic::ErrorCode::kInvalidInput, "NaN pose");
  // A frame with depth but no line: empty, with a reason.
  f = good;
  f.rgb = cv::Mat(480, 640, CV_8UC3, cv::Scalar(128, 128, 128));
  ic::RgbdLineStats stats;
  auto none = extractor.extract(f, &stats);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  EXPECT_FALSE(stats.note.empty());
  // A frame with lines but no depth near them: empty, with a reason.
  f = good;
  f.depth = cv::Mat(480, 640, CV_16UC1, cv::Scalar(0));
  f.depth.at<uint16_t>(5, 5) = 1500;
  none = extractor.extract(f, &stats);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  std::cout << "no depth near the lines -> " << stats.note << std::endl;
  EXPECT_FALSE(stats.note.empty());
}

TEST(RgbdCamera, NormalizeInvertsPlumbBob)
{
  ic::RgbdCamera c = xtionCamera();
  c.plumb_bob = {0.05, -0.12, 0.001, -0.0005, 0.02};  // an uncalibrated Xtion's order of magnitude
  ASSERT_TRUE(c.validate().ok());
  for (double x = -0.5; x <= 0.5; x += 0.1)
    for (double y = -0.4; y <= 0.4; y += 0.1)
    {
      // OpenCV's plumb_bob, tangential terms included.
      const double k1 = c.plumb_bob[0], k2 = c.plumb_bob[1], p1 = c.plumb_bob[2], p2 = c.plumb_bob[3],
                   k3 = c.plumb_bob[4];
      const double r2 = x * x + y * y;
      const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
      const double xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
      const double yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
      const Eigen::Vector2d pixel(c.intrinsics.fx * xd + c.intrinsics.cx, c.intrinsics.fy * yd + c.intrinsics.cy);
      const Eigen::Vector2d back = c.normalize(pixel);
      EXPECT_NEAR(back.x(), x, 1e-6);
      EXPECT_NEAR(back.y(), y, 1e-6);
    }
  c.plumb_bob[0] = std::nan("");
  EXPECT_FALSE(c.validate().ok());
}

// The segments extract() hands out (for the depth registration estimate, without a second detection) are
// detectSegments' own, and every 3D line's RGB segment is one of them.
TEST(RgbdLines, ExtractHandsOutTheSegmentsItDetected)
{
  std::mt19937 rng(kSeed);
  ic::LineScene scene = ic::makeRoomScene(rng);
  const ic::RgbdFrame frame = renderFrame(scene, lookAt({3.0, 2.8, 0.9}, {1.5, 0.0, 0.9}), true, rng);
  ic::RgbdLineExtractor extractor;
  std::vector<ic::Segment2d> segments;
  const auto lines = extractor.extract(frame, nullptr, nullptr, &segments);
  ASSERT_TRUE(lines.ok()) << lines.error().describe();
  const auto detected = extractor.detectSegments(frame.rgb);
  ASSERT_TRUE(detected.ok()) << detected.error().describe();
  ASSERT_EQ(segments.size(), detected->size());
  ASSERT_GT(segments.size(), lines->size() / 2);
  for (size_t i = 0; i < segments.size(); ++i)
  {
    EXPECT_EQ(segments[i].a, (*detected)[i].a);
    EXPECT_EQ(segments[i].b, (*detected)[i].b);
  }
  for (const auto& line : *lines)
    EXPECT_TRUE(std::any_of(segments.begin(), segments.end(),
                            [&](const ic::Segment2d& s) { return s.a == line.image.a && s.b == line.image.b; }));
}

namespace
{
// Depth of a plane whose depth grows by slope_m_per_px per px to the right at x = edge_x, where it is z0 (inverse
// depth affine in x).
float slantedDepth(double x, double edge_x, double z0, double slope_m_per_px)
{
  const double v = 1.0 / z0 - slope_m_per_px / (z0 * z0) * (x - edge_x);
  return v > 0.05 ? static_cast<float>(1.0 / v) : 20.0f;
}

struct PooledStep
{
  double step_m = 0.0, standard_error_m = 0.0, mean_depth_m = 0.0;
  size_t far_seen = 0, samples = 0;
};

// The sampler on 40 noisy frames of the depth image (the Xtion's noise), its steps pooled by inverse variance.
PooledStep pooledStep(const cv::Mat& truth, const ic::Segment2d& segment, const ic::DepthSamplerOptions& options,
                      std::mt19937& rng)
{
  PooledStep p;
  double sw = 0.0, swx = 0.0, z_sum = 0.0;
  for (int k = 0; k < 40; ++k)
  {
    const auto samples =
        ic::sampleDepthAlongSegment(ic::makeSensorDepth(truth, kXtionNoisePerM, false, rng), segment, options);
    for (const auto& s : samples)
    {
      p.far_seen += s.discontinuity;
      z_sum += s.depth_m;
    }
    p.samples += samples.size();
    const ic::DepthStep s = ic::measureDepthStep(samples);
    if (s.samples == 0)
      continue;
    sw += 1.0 / (s.sigma_m * s.sigma_m);
    swx += s.left_nearer_by_m / (s.sigma_m * s.sigma_m);
  }
  p.step_m = sw > 0.0 ? swx / sw : std::nan("");
  p.standard_error_m = 1.0 / std::sqrt(sw);
  p.mean_depth_m = z_sum / static_cast<double>(std::max<size_t>(1, p.samples));
  return p;
}
}  // namespace

// A flat wall seen at a grazing angle: its depth grows 1 cm per px across the edge at 2.5 m (66 deg), 2 cm per px
// at 4.5 m (window frames on a side wall). Without the slant allowance a reading counts as far when it is a jump
// behind the nearest one, so most samples saw "far" readings and those kept both sides were the ones whose deeper
// side read near: a false step of 4.6 and 12 mm at 15 and 7 standard errors over 40 frames. With it the pooled step
// is within its noise and the edge depth within a millimetre. Behind a slanted near surface a background that recedes
// faster is still far (the allowance is the smaller side's slant).
TEST(DepthSampler, NoFalseStepOnAWallSeenAtAGrazingAngle)
{
  std::mt19937 rng(kSeed);
  const ic::Segment2d segment{{32.5, 420.0}, {32.5, 60.0}};
  for (const auto& [z0, slope] : {std::pair{2.5, 0.01}, std::pair{4.5, 0.02}})
  {
    cv::Mat truth(480, 64, CV_32FC1);
    for (int y = 0; y < truth.rows; ++y)
      for (int x = 0; x < truth.cols; ++x)
        truth.at<float>(y, x) = slantedDepth(x, 32.5, z0, slope);
    ic::DepthSamplerOptions with, without;
    with.small_step_sigmas = without.small_step_sigmas = 0.0;
    without.slant_allowance = false;
    const PooledStep p = pooledStep(truth, segment, with, rng), q = pooledStep(truth, segment, without, rng);
    std::cout << z0 << " m, " << 100.0 * slope << " cm/px: pooled step " << 1000.0 * p.step_m << " +- "
              << 1000.0 * p.standard_error_m << " mm (" << p.far_seen << " of " << p.samples
              << " samples saw far readings), without the allowance " << 1000.0 * q.step_m << " +- "
              << 1000.0 * q.standard_error_m << " mm (" << q.far_seen << " of " << q.samples << ")" << std::endl;
    EXPECT_LT(std::abs(p.step_m), std::max(3.0 * p.standard_error_m, 0.0005));
    EXPECT_NEAR(p.mean_depth_m, z0, 0.001);
    EXPECT_LT(p.far_seen, p.samples / 20);
    EXPECT_GT(std::abs(q.step_m), 5.0 * q.standard_error_m);
  }
  // Near surface (left, 1 cm per px) before a background 20 cm behind it at the edge and receding 3 cm per px.
  cv::Mat occluded(480, 64, CV_32FC1);
  for (int y = 0; y < occluded.rows; ++y)
    for (int x = 0; x < occluded.cols; ++x)
      occluded.at<float>(y, x) = x <= 32 ? slantedDepth(x, 32.5, 2.5, 0.01) : slantedDepth(x, 32.5, 2.7, 0.03);
  const PooledStep p = pooledStep(occluded, segment, ic::DepthSamplerOptions(), rng);
  EXPECT_EQ(p.far_seen, p.samples);
  EXPECT_NEAR(p.mean_depth_m, 2.5, 0.002);
}
