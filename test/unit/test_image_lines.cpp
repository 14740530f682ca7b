// 2D lines: detection, merging of fragments into polylines, fine-tuning on the gradient (Eq. 8), bad input.
// Ground truth: rectangles rendered with anti-aliasing and noise by synthetic/line_scene.h.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/lines/image_lines.h"
#include "insitu_calibration/lines/line_evaluation.h"
#include "insitu_calibration/test_support/line_scene.h"

namespace ic = insitu_calibration;

namespace
{
constexpr unsigned kSeed = 20240604;

struct RectangleScene
{
  ic::LineScene scene;
  ic::CameraModel camera;
  int width = 0;
  int height = 0;
  std::vector<ic::Segment3d> rectangle;  // the 4 true edges
};

// A dark rectangle (grey 60) on a bright background (grey 190), fronto-parallel at 1 m in front of a camera with
// f = 500 px: the rectangle's centre at pixel (cx_px, cy_px), half sizes in px, rotated by angle_deg in the image.
RectangleScene makeRectangle(int width, int height, double cx_px, double cy_px, double half_w_px, double half_h_px,
                             double angle_deg, double lambda = 0.0)
{
  RectangleScene r;
  r.width = width;
  r.height = height;
  ic::Intrinsics k;
  k.fx = k.fy = 500.0;
  k.cx = 0.5 * (width - 1);
  k.cy = 0.5 * (height - 1);
  ic::DivisionModel dm;
  dm.lambda = lambda;
  dm.center = k.principalPoint();
  r.camera = ic::CameraModel(k, dm, ic::CameraPose());
  const double c = std::cos(angle_deg * M_PI / 180.0), s = std::sin(angle_deg * M_PI / 180.0);
  auto corner = [&](double sx, double sy) {
    const double u = cx_px + c * sx * half_w_px - s * sy * half_h_px;
    const double v = cy_px + s * sx * half_w_px + c * sy * half_h_px;
    return Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
  };
  const Eigen::Vector3d p0 = corner(-1, -1), p1 = corner(1, -1), p3 = corner(-1, 1);
  r.scene.quads.push_back({p0, p1 - p0, p3 - p0, 60.0});
  r.scene.quads.push_back({{-50, -50, 3.0}, {100, 0, 0}, {0, 100, 0}, 190.0});
  const auto edges = r.scene.edges();
  r.rectangle.assign(edges.begin(), edges.begin() + 4);
  return r;
}

}  // namespace

TEST(ImageLines, RenderedRectangleFineTunedWithinTenthPixel)
{
  std::cout << "seed " << kSeed << std::endl;
  std::mt19937 rng(kSeed);
  ic::LineSceneRenderOptions render;
  render.supersampling = 8;
  render.noise_sigma = 3.0;
  for (const double angle : {0.0, 7.0, 17.0, 33.0, 45.0})
  {
    const RectangleScene r = makeRectangle(320, 240, 161.3, 118.6, 90.0, 60.0, angle);
    const cv::Mat image = ic::renderGrey(r.scene, r.camera, r.width, r.height, render, rng);
    const auto truth = ic::projectEdges(r.camera, r.rectangle);
    ASSERT_EQ(truth.size(), 4u);
    for (const auto kind : {ic::SegmentDetectorKind::kFastLineDetector, ic::SegmentDetectorKind::kLsd})
    {
      ic::ImageLineOptions options;
      options.detector.kind = kind;
      ic::ImageLineStats stats;
      const auto lines = ic::extractImageLines(image, r.camera, options, &stats);
      ASSERT_TRUE(lines.ok()) << lines.error().describe();
      std::vector<int> matched(4, 0);
      for (const auto& line : *lines)
      {
        const ic::ImageLineError before = ic::measureImageLine(line.detected, r.camera.distortion(), truth);
        const ic::ImageLineError after = ic::measureImageLine(line.points, r.camera.distortion(), truth);
        ASSERT_GE(after.edge, 0) << "a line that is not a rectangle edge, angle " << angle;
        ++matched[after.edge];
        std::cout << ic::toString(kind) << " angle " << angle << " edge " << after.edge << ": detected rms "
                  << before.rms_px << " max " << before.max_px << " px, fine-tuned rms " << after.rms_px << " max "
                  << after.max_px << " px" << std::endl;
        EXPECT_LT(after.max_px, 0.1) << "angle " << angle << " edge " << after.edge;
        EXPECT_GT(line.length_px, 90.0);
      }
      // One line per edge: the fragments were merged.
      for (int e = 0; e < 4; ++e)
        EXPECT_EQ(matched[e], 1) << ic::toString(kind) << " angle " << angle << " edge " << e;
    }
  }
}

TEST(ImageLines, DistortedRectangleGivesOneCurvedPolylinePerSide)
{
  std::cout << "seed " << kSeed << std::endl;
  std::mt19937 rng(kSeed);
  ic::LineSceneRenderOptions render;
  render.supersampling = 8;
  render.noise_sigma = 2.0;
  // Barrel distortion moving the image corner 12 px inwards on 640 x 480.
  const double corner_r = std::hypot(319.5, 239.5);
  const double lambda = -12.0 / (corner_r * corner_r * (corner_r - 12.0));
  RectangleScene r = makeRectangle(640, 480, 321.0, 238.0, 270.0, 190.0, 4.0, lambda);
  // Bars in front (0.8 m) interrupt the sides: each side is detected in fragments that must be merged.
  auto bar = [&](double u0, double v0, double u1, double v1) {
    const double z = 0.8, f = 500.0, cx = 319.5, cy = 239.5;
    const Eigen::Vector3d p0((u0 - cx) * z / f, (v0 - cy) * z / f, z);
    r.scene.quads.push_back({p0, {(u1 - u0) * z / f, 0, 0}, {0, (v1 - v0) * z / f, 0}, 125.0});
  };
  bar(200, 0, 215, 479);
  bar(420, 0, 440, 479);
  bar(0, 300, 639, 312);
  const cv::Mat image = ic::renderGrey(r.scene, r.camera, r.width, r.height, render, rng);
  // Every scene edge is a candidate; the rectangle's 4 must each be found once, as one polyline.
  const auto truth = ic::projectEdges(r.camera, r.scene.edges());
  for (const bool known_distortion : {false, true})
  {
    ic::DivisionModel dm;
    dm.center = r.camera.distortion().center;
    dm.lambda = known_distortion ? lambda : 0.0;
    ic::ImageLineStats stats;
    const auto lines = ic::extractImageLines(image, dm, ic::ImageLineOptions(), &stats);
    ASSERT_TRUE(lines.ok()) << lines.error().describe();
    std::vector<int> matched(4, 0);
    for (const auto& line : *lines)
    {
      const auto before = ic::measureImageLine(line.detected, r.camera.distortion(), truth);
      const auto after = ic::measureImageLine(line.points, r.camera.distortion(), truth);
      ASSERT_GE(after.edge, 0);
      if (after.edge >= 4)
        continue;  // a bar
      ++matched[after.edge];
      std::cout << "lambda " << dm.lambda << " edge " << after.edge << ": " << line.points.size() << " points, "
                << line.fragments.size() << " fragments, detected rms " << before.rms_px << " px, fine-tuned rms "
                << after.rms_px << " max " << after.max_px << " px" << std::endl;
      EXPECT_GE(line.points.size(), 4u);  // a curve: several parts
      EXPECT_LT(after.max_px, 0.1);
      EXPECT_GT(line.length_px, 300.0);
    }
    for (int e = 0; e < 4; ++e)
      EXPECT_EQ(matched[e], 1) << "lambda " << dm.lambda << " edge " << e << " (" << stats.segments.size()
                               << " segments)";
  }
}

TEST(ImageLines, RefinerConvergesFromAnOffsetSegment)
{
  std::mt19937 rng(kSeed);
  ic::LineSceneRenderOptions render;
  render.noise_sigma = 2.0;
  const RectangleScene r = makeRectangle(320, 240, 160.0, 120.0, 100.0, 70.0, 21.0);
  const cv::Mat image = ic::renderGrey(r.scene, r.camera, r.width, r.height, render, rng);
  const auto truth = ic::projectEdges(r.camera, r.rectangle);
  auto refiner = ic::LineRefiner::create(image);
  ASSERT_TRUE(refiner.ok());
  for (const auto& edge : truth)
  {
    // The middle 80 % of the edge, moved 1.5 px across and tilted so its ends differ by 1 px.
    const Eigen::Vector2d d = (edge.b - edge.a).normalized();
    const Eigen::Vector2d n(-d.y(), d.x());
    const Eigen::Vector2d a = edge.a + 0.1 * (edge.b - edge.a) + 1.5 * n;
    const Eigen::Vector2d b = edge.b - 0.1 * (edge.b - edge.a) + 2.5 * n;
    const auto refined = refiner->refineSegment(a, b);
    ASSERT_TRUE(refined.ok()) << refined.error().describe();
    for (const auto& p : {refined->a, refined->b})
    {
      const auto dist = ic::distanceToEdge(r.camera.distortion(), edge, p);
      ASSERT_TRUE(dist.has_value());
      EXPECT_LT(*dist, 0.1);
    }
    EXPECT_GT(refined->contrast, 100.0);  // 190 - 60
    EXPECT_GT(refined->support, 0.9);
  }
  // A segment over a flat region finds no edge.
  const auto flat = refiner->refineSegment({150.0, 110.0}, {170.0, 125.0});
  ASSERT_FALSE(flat.ok());
  EXPECT_EQ(flat.error().code(), ic::ErrorCode::kNotEnoughData);
}

TEST(ImageLines, BadInputGivesErrorsOrEmptyResultsWithAReason)
{
  const ic::DivisionModel dm;
  // Empty image.
  auto empty = ic::extractImageLines(cv::Mat(), dm);
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().code(), ic::ErrorCode::kInvalidInput);
  // Unsupported type.
  auto wrong_type = ic::extractImageLines(cv::Mat(50, 50, CV_64FC3, cv::Scalar(0)), dm);
  ASSERT_FALSE(wrong_type.ok());
  EXPECT_EQ(wrong_type.error().code(), ic::ErrorCode::kInvalidInput);
  // Non-finite distortion.
  ic::DivisionModel nan_dm;
  nan_dm.lambda = std::nan("");
  auto bad_model = ic::extractImageLines(cv::Mat(50, 50, CV_8UC1, cv::Scalar(0)), nan_dm);
  ASSERT_FALSE(bad_model.ok());
  EXPECT_EQ(bad_model.error().code(), ic::ErrorCode::kInvalidInput);
  // A flat image: no error, no line, and a reason.
  ic::ImageLineStats stats;
  auto flat = ic::extractImageLines(cv::Mat(120, 160, CV_8UC3, cv::Scalar(90, 90, 90)), dm, {}, &stats);
  ASSERT_TRUE(flat.ok());
  EXPECT_TRUE(flat->empty());
  EXPECT_FALSE(stats.note.empty());
  // Tiny image.
  auto tiny = ic::extractImageLines(cv::Mat(1, 1, CV_8UC1, cv::Scalar(0)), dm);
  EXPECT_TRUE(!tiny.ok() || tiny->empty());
  // Refiner.
  EXPECT_FALSE(ic::LineRefiner::create(cv::Mat()).ok());
  ic::RefinerOptions bad_options;
  bad_options.half_width_px = 0.0;
  EXPECT_FALSE(ic::LineRefiner::create(cv::Mat(10, 10, CV_8UC1), bad_options).ok());
  auto refiner = ic::LineRefiner::create(cv::Mat(40, 40, CV_8UC1, cv::Scalar(0)));
  ASSERT_TRUE(refiner.ok());
  EXPECT_FALSE(refiner->refineSegment({std::nan(""), 1.0}, {10.0, 10.0}).ok());
  EXPECT_FALSE(refiner->refineSegment({5.0, 5.0}, {5.0, 5.0}).ok());
  EXPECT_FALSE(refiner->refinePolyline({{5.0, 5.0}}).ok());
  // A segment leaving the image is not an error that throws: it finds no edge.
  EXPECT_FALSE(refiner->refineSegment({-100.0, -100.0}, {-50.0, -60.0}).ok());
  // Detector on every supported type.
  ic::SegmentDetector detector;
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_32FC1})
  {
    cv::Mat img(60, 80, type, cv::Scalar::all(0));
    auto segments = detector.detect(img);
    ASSERT_TRUE(segments.ok()) << cv::typeToString(type) << ": " << segments.error().describe();
    EXPECT_TRUE(segments->empty());
  }
}

namespace
{
// An image from a grey level per point (area-sampled with n x n samples per pixel) plus Gaussian noise.
template <typename F>
cv::Mat renderFunction(int width, int height, F grey, double noise_sigma, std::mt19937& rng, int n = 8)
{
  std::normal_distribution<double> noise(0.0, noise_sigma);
  cv::Mat image(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
    {
      double sum = 0.0;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
          sum += grey(x - 0.5 + (i + 0.5) / n, y - 0.5 + (j + 0.5) / n);
      image.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(sum / (n * n) + noise(rng));
    }
  return image;
}

// The largest distance (px) from a line, sampled at every 5 % of each of its polyline's segments, to the straight
// edge y = edge_y(x) of the given slope, wherever keep(x) holds (away from a junction, say).
template <typename Edge, typename Keep>
double largestDistanceToEdge(const ic::ImageLine& line, Edge edge_y, double slope, Keep keep)
{
  double largest = 0.0;
  for (size_t k = 0; k + 1 < line.points.size(); ++k)
    for (double t = 0.0; t <= 1.0; t += 0.05)
    {
      const Eigen::Vector2d p = line.points[k] + t * (line.points[k + 1] - line.points[k]);
      if (keep(p.x()))
        largest = std::max(largest, std::abs(p.y() - edge_y(p.x())) / std::sqrt(1.0 + slope * slope));
    }
  return largest;
}
}  // namespace

// A second, weaker edge of the same polarity 2.2 px beside the edge (a ceiling tile's edge beside the wall-ceiling
// crease, the far side of a thin strip): the wide window's centroids are pulled towards it; the narrow second stage
// (polish_half_width_px) leaves it out. Edge at x = 100.3 + 0.05 y, grey 60 | 160 | 190.
TEST(LineRefiner, CloseParallelEdgeDoesNotPullTheFineTunedEdge)
{
  std::mt19937 rng(kSeed);
  auto edge_x = [](double y) { return 100.3 + 0.05 * y; };
  const cv::Mat image = renderFunction(
      240, 240, [&](double x, double y) { return x < edge_x(y) ? 60.0 : (x < edge_x(y) + 2.2 ? 160.0 : 190.0); }, 2.0,
      rng);
  auto error = [&](const ic::RefinedSegment& r) {
    return std::max(std::abs(r.a.x() - edge_x(r.a.y())), std::abs(r.b.x() - edge_x(r.b.y())));
  };
  const Eigen::Vector2d a(edge_x(20.0) + 0.4, 20.0), b(edge_x(220.0) - 0.3, 220.0);
  ic::RefinerOptions polished;
  auto refiner = ic::LineRefiner::create(image, polished);
  ASSERT_TRUE(refiner.ok());
  const auto with = refiner->refineSegment(a, b);
  ASSERT_TRUE(with.ok()) << with.error().describe();
  ic::RefinerOptions wide_only;
  wide_only.polish_half_width_px = 0.0;
  auto wide = ic::LineRefiner::create(image, wide_only);
  const auto without = wide->refineSegment(a, b);
  ASSERT_TRUE(without.ok()) << without.error().describe();
  std::cout << "largest end-point error: wide window " << error(*without) << " px, then narrow " << error(*with)
            << " px; flank asymmetry " << without->asymmetry << " / " << with->asymmetry << std::endl;
  EXPECT_LT(error(*with), 0.05);
  EXPECT_GT(error(*without), 0.1);  // the first version's bias
}

// A polyline along two nearly collinear edges, 0.9 px apart where they meet (a table top's far edge running on as a
// floor line behind it): fine-tuned, its parts disagree at the shared vertex, and the line is split there, so each
// line lies on one edge.
TEST(ImageLines, PolylineAlongTwoNearlyCollinearEdgesIsSplit)
{
  std::mt19937 rng(kSeed);
  auto edge_y = [](double x) { return x < 300.0 ? 100.3 + 0.01 * x : 101.2 + 0.01 * x; };
  const cv::Mat image = renderFunction(
      600, 200, [&](double x, double y) { return y < edge_y(x) ? 190.0 : 70.0; }, 2.0, rng, 6);
  auto worst = [&](const ic::ImageLine& line) {  // not at the step itself
    return largestDistanceToEdge(line, edge_y, 0.01, [](double x) { return std::abs(x - 300.0) > 3.0; });
  };
  ic::DivisionModel none;
  none.center = Eigen::Vector2d(299.5, 99.5);
  for (const double split : {0.3, 0.0})
  {
    ic::ImageLineOptions options;
    options.split_gap_px = split;
    options.split_kink_px = split > 0.0 ? options.split_kink_px : 0.0;  // the kink test splits this line too
    ic::ImageLineStats stats;
    const auto lines = ic::extractImageLines(image, none, options, &stats);
    ASSERT_TRUE(lines.ok()) << lines.error().describe();
    double max_error = 0.0;
    for (const auto& line : *lines)
      max_error = std::max(max_error, worst(line));
    std::cout << "split_gap_px " << split << ": " << stats.segments.size() << " segments, " << stats.polylines
              << " polylines, " << lines->size() << " lines, " << stats.splits << " split; largest distance to "
              << "the edge " << max_error << " px" << std::endl;
    ASSERT_GE(lines->size(), 1u);
    if (split > 0.0)
    {
      EXPECT_LT(max_error, 0.15);
      EXPECT_GE(stats.splits, 1);
    }
    else if (stats.polylines == 1)
    {
      EXPECT_GT(max_error, 0.3);  // the first version: one line across both edges
    }
  }
}

// An edge that ends where a nearly collinear edge takes over 1 px aside (a door frame's top running on as the wall's
// edge behind it): a part straddling the junction is fine-tuned onto the longer edge, and the samples beyond the
// junction lie off the line. The part reports that run (off_b_px) and the line ends at the junction instead of running
// on beside the other edge.
TEST(ImageLines, LineEndsWhereANearlyCollinearEdgeTakesOver)
{
  std::mt19937 rng(kSeed);
  constexpr double kJunction = 420.0, kEnd = 440.0;
  auto edge_y = [&](double x) { return x < kJunction ? 100.3 + 0.01 * x : 101.3 + 0.01 * x; };
  const cv::Mat image = renderFunction(
      520, 200, [&](double x, double y) { return y < edge_y(x) || x >= kEnd ? 190.0 : 70.0; }, 2.0, rng, 6);

  // The part alone: 400 px on the first edge, 20 px on the second.
  auto refiner = ic::LineRefiner::create(image);
  ASSERT_TRUE(refiner.ok());
  const Eigen::Vector2d a(20.0, edge_y(20.0) + 0.3), b(kEnd, edge_y(kEnd) - 0.5);
  const auto part = refiner->refineSegment(a, b);
  ASSERT_TRUE(part.ok()) << part.error().describe();
  std::cout << "straddling part: off the line " << part->off_a_px << " px at a, " << part->off_b_px << " px at b"
            << std::endl;
  EXPECT_EQ(part->off_a_px, 0.0);
  EXPECT_NEAR(part->off_b_px, kEnd - kJunction, 3.0);
  // On one edge only: nothing off.
  const auto clean = refiner->refineSegment(a, Eigen::Vector2d(kJunction - 20.0, edge_y(kJunction - 20.0)));
  ASSERT_TRUE(clean.ok()) << clean.error().describe();
  EXPECT_EQ(clean->off_a_px, 0.0);
  EXPECT_EQ(clean->off_b_px, 0.0);

  // The whole extraction: every line within 0.1 px of the edge under it.
  auto worst = [&](const ic::ImageLine& line) {
    return largestDistanceToEdge(line, edge_y, 0.01,
                                 [&](double x) { return std::abs(x - kJunction) > 2.0 && x < kEnd - 2.0; });
  };
  ic::DivisionModel none;
  none.center = Eigen::Vector2d(259.5, 99.5);
  for (const double tolerance : {0.3, 0.0})
  {
    ic::ImageLineOptions options;
    options.refiner.end_tolerance_px = tolerance;
    ic::ImageLineStats stats;
    const auto lines = ic::extractImageLines(image, none, options, &stats);
    ASSERT_TRUE(lines.ok()) << lines.error().describe();
    double max_error = 0.0;
    for (const auto& line : *lines)
      if (std::abs(line.points.front().y() - line.points.back().y()) < 20.0)  // the horizontal edges
        max_error = std::max(max_error, worst(line));
    std::cout << "end_tolerance_px " << tolerance << ": " << stats.segments.size() << " segments, " << stats.polylines
              << " polylines, " << lines->size() << " lines, " << stats.trimmed
              << " trimmed; largest distance to the edge " << max_error << " px" << std::endl;
    ASSERT_GE(lines->size(), 1u);
    if (tolerance > 0.0)
    {
      EXPECT_LT(max_error, 0.1);
    }
  }
}

// An edge running into another one at 2 degrees (a sloping shadow line meeting a wall's edge): the part of the
// polyline across the junction (20 px on one edge, 50 px on the other) is fine-tuned between the two; its centroids
// are fitted much better by two lines broken at the junction, so it is fine-tuned again on its longer side and the
// line is split and trimmed at the junction.
TEST(ImageLines, PartAcrossTwoEdgesMeetingAtAnAngleIsBroken)
{
  std::mt19937 rng(kSeed);
  constexpr double kJunction = 300.0;
  auto edge_y = [&](double x) { return x < kJunction ? 100.3 + 0.01 * x : 103.3 + 0.045 * (x - kJunction); };
  const cv::Mat image = renderFunction(
      600, 200, [&](double x, double y) { return y < edge_y(x) ? 190.0 : 70.0; }, 2.0, rng, 6);
  auto worst = [&](const ic::ImageLine& line) {
    return largestDistanceToEdge(line, edge_y, 0.045, [&](double x) { return std::abs(x - kJunction) > 3.0; });
  };
  ic::DivisionModel none;
  none.center = Eigen::Vector2d(299.5, 99.5);
  for (const double min_break : {8.0, 0.0})
  {
    ic::ImageLineOptions options;
    options.refiner.min_break_px = min_break;
    ic::ImageLineStats stats;
    const auto lines = ic::extractImageLines(image, none, options, &stats);
    ASSERT_TRUE(lines.ok()) << lines.error().describe();
    double max_error = 0.0;
    for (const auto& line : *lines)
      max_error = std::max(max_error, worst(line));
    std::cout << "min_break_px " << min_break << ": " << stats.segments.size() << " segments, " << stats.polylines
              << " polylines, " << lines->size() << " lines, " << stats.splits << " split, " << stats.trimmed
              << " trimmed; largest distance to the edge " << max_error << " px" << std::endl;
    ASSERT_GE(lines->size(), 1u);
    if (min_break > 0.0)
      EXPECT_LT(max_error, 0.1);
    else
      EXPECT_GT(max_error, 0.3);  // the part fitted between the two edges
  }
}

namespace
{
// A thin line (a joint between tiles, 0.6 px wide) at x = 100.3 + 0.05 y, grey `line_grey` on a background of 80
// rising by 0.1 grey level per px across it, blurred by a Gaussian of blur_px (a lens): a bump of 2-3 px with no step
// across it.
cv::Mat renderThinLine(double line_grey, double blur_px, std::mt19937& rng)
{
  auto grey = [&](double x, double y) {
    const double d = x - (100.3 + 0.05 * y);
    return std::abs(d) < 0.3 ? line_grey : 80.0 + 0.1 * x;
  };
  cv::Mat image = renderFunction(240, 240, grey, 0.0, rng);
  cv::Mat blurred;
  image.convertTo(blurred, CV_32F);
  cv::GaussianBlur(blurred, blurred, cv::Size(), blur_px, blur_px);
  cv::Mat noise(blurred.size(), CV_32F);
  cv::randn(noise, 0.0, 1.5);
  blurred += noise;
  blurred.convertTo(image, CV_8U);
  return image;
}

double thinLineError(const Eigen::Vector2d& p)
{
  return std::abs(p.x() - (100.3 + 0.05 * p.y())) / std::sqrt(1.0 + 0.05 * 0.05);
}
}  // namespace

// A thin line has no step across the window: as an edge it is not found; as a thin line (RefinerOptions::thin_lines)
// it is fitted at its centre from a start on its flank, bright or dark alike.
TEST(LineRefiner, ThinLineIsFittedAtItsCentre)
{
  for (const double line_grey : {200.0, 10.0})
  {
    std::mt19937 rng(kSeed);
    const cv::Mat image = renderThinLine(line_grey, 0.9, rng);
    const Eigen::Vector2d a(100.3 + 0.05 * 20.0 + 1.2, 20.0), b(100.3 + 0.05 * 220.0 + 1.0, 220.0);
    ic::RefinerOptions edges_only;
    auto refiner = ic::LineRefiner::create(image, edges_only);
    ASSERT_TRUE(refiner.ok());
    EXPECT_FALSE(refiner->refineSegment(a, b).ok()) << "grey " << line_grey << ": a thin line found as an edge";
    ic::RefinerOptions thin;
    thin.thin_lines = true;
    auto thin_refiner = ic::LineRefiner::create(image, thin);
    const auto r = thin_refiner->refineSegment(a, b);
    ASSERT_TRUE(r.ok()) << "grey " << line_grey << ": " << r.error().describe();
    EXPECT_TRUE(r->thin_line);
    std::cout << "thin line of grey " << line_grey << ": end points " << thinLineError(r->a) << ", "
              << thinLineError(r->b) << " px from its centre" << std::endl;
    EXPECT_LT(thinLineError(r->a), 0.05);
    EXPECT_LT(thinLineError(r->b), 0.05);
  }
}

// With thin lines on, a step edge is still fitted as an edge, where it was.
TEST(LineRefiner, StepEdgeIsNotTakenForAThinLine)
{
  std::mt19937 rng(kSeed);
  auto edge_x = [](double y) { return 100.3 + 0.05 * y; };
  const cv::Mat image = renderFunction(
      240, 240, [&](double x, double y) { return x < edge_x(y) ? 60.0 : 160.0; }, 2.0, rng);
  const Eigen::Vector2d a(edge_x(20.0) + 0.8, 20.0), b(edge_x(220.0) - 0.6, 220.0);
  ic::RefinerOptions thin;
  thin.thin_lines = true;
  const auto with = ic::LineRefiner::create(image, thin)->refineSegment(a, b);
  const auto without = ic::LineRefiner::create(image, ic::RefinerOptions())->refineSegment(a, b);
  ASSERT_TRUE(with.ok() && without.ok());
  EXPECT_FALSE(with->thin_line);
  EXPECT_LT((with->a - without->a).norm() + (with->b - without->b).norm(), 1e-12);
}

// With thin lines, line extraction finds a thin line once, at its centre.
TEST(ImageLines, ThinLineGivesOneLineAtItsCentre)
{
  std::mt19937 rng(kSeed);
  const cv::Mat image = renderThinLine(200.0, 0.9, rng);
  ic::ImageLineStats stats;
  ic::ImageLineOptions options;
  options.refiner.thin_lines = true;
  const auto lines = ic::extractImageLines(image, ic::DivisionModel(), options, &stats);
  ASSERT_TRUE(lines.ok()) << lines.error().describe();
  std::cout << stats.segments.size() << " segments, " << stats.polylines << " polylines, " << stats.duplicates
            << " duplicates dropped, " << lines->size() << " lines" << std::endl;
  ASSERT_EQ(lines->size(), 1u);
  EXPECT_GT((*lines)[0].length_px, 180.0);
  for (const Eigen::Vector2d& p : (*lines)[0].points)
    EXPECT_LT(thinLineError(p), 0.1);
}

namespace
{
ic::ImageLine straightLine(const Eigen::Vector2d& a, const Eigen::Vector2d& b, bool thin)
{
  ic::ImageLine line;
  line.points = {a, b};
  line.parts.resize(1);
  line.parts[0].thin_line = thin;
  line.length_px = (b - a).norm();
  return line;
}
}  // namespace

// Of two fine-tuned lines on one thin line's centre the shorter goes; edges close beside each other, a thin line 1 px
// beside another line, or one overlapping less than half its length, stay.
TEST(ImageLines, DuplicateThinLinesAreDroppedAndOnlyThey)
{
  std::vector<ic::ImageLine> lines = {
      straightLine({10, 10}, {200, 10}, true),      // a thin line
      straightLine({30, 10.2}, {150, 10.1}, true),  // the same, from its other flank: dropped
      straightLine({10, 40}, {200, 40}, false),     // two edges 0.3 px apart: both stay
      straightLine({10, 40.3}, {200, 40.3}, false),
      straightLine({10, 70}, {200, 70}, false),  // a thin line 1 px beside an edge: stays
      straightLine({10, 71}, {150, 71}, true),
      straightLine({10, 100}, {100, 100}, true),  // overlapping 40 of its 90 px: stays
      straightLine({60, 100.1}, {160, 100.1}, true),
  };
  std::vector<ic::ImageLine> kept = lines;
  EXPECT_EQ(ic::dropDuplicateThinLines(0.5, &kept), 1);
  ASSERT_EQ(kept.size(), lines.size() - 1);
  for (const ic::ImageLine& line : kept)
    EXPECT_FALSE(line.points[0].x() == 30.0) << "the shorter duplicate was kept";
  std::vector<ic::ImageLine> all = lines;
  EXPECT_EQ(ic::dropDuplicateThinLines(0.0, &all), 0);
  EXPECT_EQ(all.size(), lines.size());
}
