// The simulator's realistic appearance (world file "appearance" block) and materials (planks, bricks, tiles, natural
// structure): each effect measurably present when on and absent when off, against the clean render or the true
// surfaces; material joints as true texture edges; determinism; refused values; the generator's realistic default
// and its plain option.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/sensor_models.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "insitu_calibration/simulation/world_generator.h"

namespace sim = insitu_calibration::simulation;

namespace
{
const std::string kRoute = "route: {waypoints: [[0, 0], [1, 0]]}\n";

sim::World parse(const std::string& text)
{
  auto world = sim::parseWorld(text, "appearance.yaml");
  EXPECT_TRUE(world) << world.error().describe();
  return world ? std::move(*world) : sim::World{};
}

// One wall facing the camera at the origin (looking along +x), at distance d; optionally a near panel at distance
// near covering y > 0 (the image's left half), making a vertical depth step at the image centre.
sim::World wallWorld(double d, const std::string& texture = "{color: [200, 200, 200]}", double near = 0.0)
{
  std::string text = "lighting: {ambient: 1.0, diffuse: 0.0}\nsurfaces:\n  - name: wall\n    rectangle: {center: [" +
                     std::to_string(d) + ", 0, 0], normal: [-1, 0, 0], size: [40, 40]}\n    texture: " + texture + "\n";
  if (near > 0.0)
    text += "  - name: panel\n    rectangle: {center: [" + std::to_string(near) +
            ", 10, 0], normal: [-1, 0, 0], size: [20, 40]}\n";
  return parse(text + kRoute + "fixed_cameras: []\n");
}

sim::ViewCamera lookingAlongX(double cx_shift = 0.0, double cy_shift = 0.0)
{
  sim::ViewCamera cam;
  cam.width = 640;
  cam.height = 480;
  cam.intrinsics = {570.0, 570.0, 0.0, 319.5 + cx_shift, 239.5 + cy_shift};
  Eigen::Matrix3d r;
  r.col(0) = -Eigen::Vector3d::UnitY();
  r.col(1) = -Eigen::Vector3d::UnitZ();
  r.col(2) = Eigen::Vector3d::UnitX();
  cam.world_from_camera.linear() = r;
  return cam;
}

double meanGreen(const cv::Mat& rgb, int x, int y, int half = 3)
{
  return cv::mean(rgb(cv::Rect(x - half, y - half, 2 * half + 1, 2 * half + 1)))[1];
}

// The spread (sigma, px) of an edge's blur along image row y: the standard deviation of the derivative profile.
double edgeSpreadPx(const cv::Mat& rgb, int y)
{
  double sum = 0.0, sum_x = 0.0, sum_xx = 0.0;
  for (int x = 1; x < rgb.cols; ++x)
  {
    const double d = std::abs(double(rgb.at<cv::Vec3b>(y, x)[1]) - rgb.at<cv::Vec3b>(y, x - 1)[1]);
    sum += d;
    sum_x += d * x;
    sum_xx += d * x * x;
  }
  const double mean = sum_x / sum;
  return std::sqrt(sum_xx / sum - mean * mean);
}

// Mean absolute step across the 8 x 8 block boundaries over the mean step inside blocks (1 without JPEG).
double blockiness(const cv::Mat& rgb)
{
  double across = 0.0, inside = 0.0;
  size_t n_across = 0, n_inside = 0;
  for (int y = 0; y < rgb.rows; ++y)
    for (int x = 1; x < rgb.cols; ++x)
    {
      const double d = std::abs(double(rgb.at<cv::Vec3b>(y, x)[1]) - rgb.at<cv::Vec3b>(y, x - 1)[1]);
      (x % 8 == 0 ? across : inside) += d;
      ++(x % 8 == 0 ? n_across : n_inside);
    }
  return (across / n_across) / (inside / n_inside);
}
}  // namespace

TEST(Appearance, VignettingFollowsCosFourth)
{
  const sim::World world = wallWorld(2.0);
  const sim::ViewCamera cam = lookingAlongX();
  const cv::Mat clean = sim::Renderer(world).render(cam).rgb;
  sim::CameraAppearance look;
  EXPECT_TRUE(cv::norm(sim::applyCameraOptics(clean, look, cam), clean, cv::NORM_INF) == 0);  // off: unchanged
  look.vignetting = 0.5;
  const cv::Mat out = sim::applyCameraOptics(clean, look, cam);
  const double r2 = (std::pow(316.5 / 570.0, 2) + std::pow(236.5 / 570.0, 2));  // the corner patch's centre
  const double expected = 1.0 - 0.5 * (1.0 - 1.0 / ((1.0 + r2) * (1.0 + r2)));
  const double ratio = meanGreen(out, 636, 476) / meanGreen(out, 320, 240);
  std::printf("vignetting 0.5: corner/centre %.3f (cos^4 model %.3f)\n", ratio, expected);
  EXPECT_NEAR(ratio, expected, 0.01);
  EXPECT_NEAR(meanGreen(clean, 636, 476) / meanGreen(clean, 320, 240), 1.0, 1e-9);
}

TEST(Appearance, BlurWidensEdgesByItsSigma)
{
  // Stripes 1 m wide: one vertical black/white edge near the image centre at 2 m.
  const sim::World world = wallWorld(2.0,
                                     "{pattern: stripes, color: [230, 230, 230], color2: [30, 30, 30], "
                                     "cell: [1, 1], offset: [-19.97, 0]}");
  const sim::ViewCamera cam = lookingAlongX();
  const cv::Mat clean = sim::Renderer(world).render(cam).rgb;
  const cv::Mat centre = clean(cv::Rect(200, 0, 240, 480));
  sim::CameraAppearance look;
  look.blur_sigma_px = 2.0;
  const cv::Mat blurred = sim::applyCameraOptics(clean, look, cam)(cv::Rect(200, 0, 240, 480));
  const double sharp = edgeSpreadPx(centre, 240), wide = edgeSpreadPx(blurred, 240);
  const double added = std::sqrt(wide * wide - sharp * sharp);
  std::printf("edge spread: %.2f px sharp, %.2f px blurred (added sigma %.2f, set 2.0)\n", sharp, wide, added);
  EXPECT_LT(sharp, 0.7);
  EXPECT_NEAR(added, 2.0, 0.15);
}

TEST(Appearance, ExposureAndWhiteBalanceScaleChannelsAndSaturate)
{
  const sim::World world = wallWorld(2.0, "{color: [100, 120, 140]}");
  const sim::ViewCamera cam = lookingAlongX();
  const cv::Mat clean = sim::Renderer(world).render(cam).rgb;
  sim::CameraAppearance look;
  look.exposure = 1.2;
  look.white_balance = Eigen::Vector3d(1.1, 1.0, 0.8);
  const cv::Vec3b p = sim::applyCameraOptics(clean, look, cam).at<cv::Vec3b>(240, 320);
  EXPECT_EQ(p[0], 132);  // 100 * 1.2 * 1.1
  EXPECT_EQ(p[1], 144);  // 120 * 1.2
  EXPECT_EQ(p[2], 134);  // 140 * 1.2 * 0.8 = 134.4
  look.exposure = 3.0;
  EXPECT_EQ(sim::applyCameraOptics(clean, look, cam).at<cv::Vec3b>(240, 320)[1], 255);  // saturated
}

TEST(Appearance, JpegLeavesBlocksAndIsDeterministic)
{
  // A smooth gradient with sensor noise: JPEG smooths inside its 8 x 8 blocks, not across them.
  cv::Mat img(240, 320, CV_8UC3);
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x)
      img.at<cv::Vec3b>(y, x) = cv::Vec3b(60 + x / 3, 80 + y / 3, 120);
  const cv::Mat noisy = sim::addImageNoise(img, {3.0, 0.02}, 5);
  const cv::Mat low = sim::jpegRoundTrip(noisy, 30), high = sim::jpegRoundTrip(noisy, 95);
  const double b_off = blockiness(noisy), b_low = blockiness(low), b_high = blockiness(high);
  std::printf("blockiness: %.3f without JPEG, %.3f at quality 95, %.3f at 30\n", b_off, b_high, b_low);
  EXPECT_NEAR(b_off, 1.0, 0.05);
  EXPECT_GT(b_low, 1.3);
  EXPECT_GT(cv::norm(low, noisy, cv::NORM_L1), cv::norm(high, noisy, cv::NORM_L1));
  EXPECT_EQ(cv::norm(sim::jpegRoundTrip(noisy, 30), low, cv::NORM_INF), 0.0);
}

// A depth step from a panel at 1 m to a wall at 2 m: flying pixels take depths in between, only at the step.
TEST(Appearance, FlyingPixelsOnlyAtDepthSteps)
{
  const sim::World world = wallWorld(2.0, "{color: [200, 200, 200]}", 1.0);
  const sim::ViewCamera cam = lookingAlongX();
  sim::RenderOptions ro;
  ro.color = false;
  const sim::RenderedView view = sim::Renderer(world).render(cam, ro);
  sim::DepthSensorConfig exact;  // no sensor noise: only the flying pixels (and the mm rounding)
  exact.sigma_coefficient = 0.0;
  exact.disparity_subpixel = 0.0;
  auto between = [&](const cv::Mat& depth, int* off_step) {
    int count = 0;
    *off_step = 0;
    for (int y = 0; y < depth.rows; ++y)
      for (int x = 0; x < depth.cols; ++x)
        if (depth.at<uint16_t>(y, x) > 1005 && depth.at<uint16_t>(y, x) < 1995)
        {
          ++count;
          *off_step += std::abs(x - 319.5) > 1.0 ? 1 : 0;
        }
    return count;
  };
  sim::DepthAppearance look;
  int off_step = 0;
  EXPECT_EQ(between(sim::simulateXtionDepth(view, world, cam, exact, true, 3, look), &off_step), 0);
  look.flying_pixels = 1.0;
  const int all = between(sim::simulateXtionDepth(view, world, cam, exact, true, 3, look), &off_step);
  EXPECT_EQ(off_step, 0);
  EXPECT_GT(all, 0.9 * 2 * 480);  // both columns at the step
  look.flying_pixels = 0.5;
  const int half = between(sim::simulateXtionDepth(view, world, cam, exact, true, 3, look), &off_step);
  std::printf("flying pixels at a 1 m step over 480 rows: %d at probability 1, %d at 0.5\n", all, half);
  EXPECT_NEAR(half, 0.5 * all, 0.1 * all);
  EXPECT_EQ(between(sim::simulateXtionDepth(view, world, cam, exact, false, 3, look), &off_step), 0);  // noise off
}

// The misregistered depth at pixel p is the true depth of the surface seen at p + shift in the colour image.
TEST(Appearance, MisregistrationShiftsDepthAgainstTheTrueSurface)
{
  const std::string text =
      "surfaces:\n  - name: wall\n    rectangle: {center: [2, 0, 0], normal: [-1, 0.8, 0.5], "
      "size: [40, 40]}\n" +
      kRoute + "fixed_cameras: []\n";
  const sim::World world = parse(text);
  sim::RenderOptions ro;
  ro.color = false;
  const Eigen::Vector2d shift(0.7, -0.4);
  const sim::ViewCamera cam = lookingAlongX(), moved = lookingAlongX(-shift.x(), -shift.y());
  const sim::RenderedView view = sim::Renderer(world).render(cam, ro);
  const sim::RenderedView truth = sim::Renderer(world).render(moved, ro);  // pixel p there sees cam's p + shift
  const sim::RenderedView registered = sim::misregisterDepth(view, shift);
  double worst = 0.0, plain_worst = 0.0;
  for (int y = 5; y < 475; ++y)
    for (int x = 5; x < 635; ++x)
    {
      worst = std::max(worst, double(std::abs(registered.depth.at<float>(y, x) - truth.depth.at<float>(y, x))));
      plain_worst = std::max(plain_worst, double(std::abs(view.depth.at<float>(y, x) - truth.depth.at<float>(y, x))));
    }
  std::printf("misregistration (0.7, -0.4) px on a slanted wall: %.2e m off the shifted truth, %.1f mm unshifted\n",
              worst, 1e3 * plain_worst);
  EXPECT_LT(worst, 1e-5);
  EXPECT_GT(plain_worst, 1e-3);
}

TEST(Appearance, LowFrequencyDepthErrorIsSmoothAndSized)
{
  const sim::World world = wallWorld(2.0);
  const sim::ViewCamera cam = lookingAlongX();
  sim::RenderOptions ro;
  ro.color = false;
  const sim::RenderedView view = sim::Renderer(world).render(cam, ro);
  sim::DepthSensorConfig exact;
  exact.sigma_coefficient = 0.0;
  exact.disparity_subpixel = 0.0;
  sim::DepthAppearance look;
  look.low_frequency_coefficient = 1e-3;  // sigma 4 mm at 2 m
  look.low_frequency_px = 80.0;
  const cv::Mat plain = sim::simulateXtionDepth(view, world, cam, exact, true, 9, {});
  EXPECT_EQ(cv::countNonZero(plain != 2000), 0);
  double sum2 = 0.0, neighbours = 0.0;
  size_t n = 0;
  for (uint64_t seed = 1; seed <= 4; ++seed)
  {
    const cv::Mat depth = sim::simulateXtionDepth(view, world, cam, exact, true, seed, look);
    for (int y = 0; y < 480; y += 4)
      for (int x = 0; x + 4 < 640; x += 4)
      {
        const double e = depth.at<uint16_t>(y, x) - 2000.0, e4 = depth.at<uint16_t>(y, x + 4) - 2000.0;
        sum2 += e * e;
        neighbours += (e - e4) * (e - e4);
        ++n;
      }
  }
  const double sigma = std::sqrt(sum2 / n), step = std::sqrt(neighbours / n);
  std::printf("low-frequency depth error at 2 m: sigma %.2f mm (set 4.0), rms change over 4 px %.2f mm\n", sigma, step);
  EXPECT_NEAR(sigma, 4.0, 0.6);
  EXPECT_LT(step, 0.3 * sigma);  // smooth: pixels 4 apart nearly equal
}

TEST(Appearance, WorldFileBlockIsReadAndBadValuesAreRefusedByKey)
{
  const std::string walls =
      "surfaces: [{name: wall, rectangle: {center: [2, 0, 0], normal: [-1, 0, 0], size: [4, "
      "4]}}]\n" +
      kRoute;
  const std::string camera =
      "fixed_cameras: [{name: cam, width: 64, height: 48, fx: 50, position: [0, 0, 0], look_at: [1, 0, 0]";
  const sim::World world =
      parse(walls +
            "appearance:\n  xtion_rgb: {blur_sigma_px: 0.5}\n  fixed_cameras: {vignetting: 0.4, jpeg_quality: 80}\n"
            "  depth: {flying_pixels: 0.3, misregistration_px: [0.5, -0.2]}\n" +
            camera +
            "}, {name: cam2, width: 64, height: 48, fx: 50, position: [0, 0, 0], look_at: [1, 0, 0], "
            "appearance: {jpeg_quality: 0, exposure: 0.8}}]\n");
  ASSERT_EQ(world.fixed_cameras.size(), 2u);
  EXPECT_EQ(world.appearance.xtion_rgb.blur_sigma_px, 0.5);
  EXPECT_EQ(world.fixed_cameras[0].appearance.jpeg_quality, 80);
  EXPECT_EQ(world.fixed_cameras[0].appearance.vignetting, 0.4);
  EXPECT_EQ(world.fixed_cameras[1].appearance.jpeg_quality, 0);  // its own block overrides the default...
  EXPECT_EQ(world.fixed_cameras[1].appearance.vignetting, 0.4);  // ...key by key
  EXPECT_EQ(world.fixed_cameras[1].appearance.exposure, 0.8);
  EXPECT_EQ(world.appearance.depth.misregistration_px, Eigen::Vector2d(0.5, -0.2));
  EXPECT_TRUE(parse(walls + camera + "}]\n").fixed_cameras[0].appearance.neutral());  // none by default

  const std::pair<std::string, std::string> bad[] = {
      {"appearance: {xtion_rgb: {vignetting: 1.5}}\n" + camera + "}]\n", "appearance.xtion_rgb.vignetting"},
      {"appearance: {fixed_cameras: {exposure: 0}}\n" + camera + "}]\n", "appearance.fixed_cameras.exposure"},
      {"appearance: {xtion_rgb: {blur_sigma_px: .nan}}\n" + camera + "}]\n", "appearance.xtion_rgb.blur_sigma_px"},
      {"appearance: {xtion_rgb: {white_balance: [1, 1e9, 1]}}\n" + camera + "}]\n", "white_balance"},
      {"appearance: {depth: {misregistration_px: [20, 0]}}\n" + camera + "}]\n", "depth.misregistration_px"},
      {"appearance: {depth: {flying_pixels: -1}}\n" + camera + "}]\n", "depth.flying_pixels"},
      {"appearance: {depth: {low_frequency_px: 0}}\n" + camera + "}]\n", "depth.low_frequency_px"},
      {"appearance: {depth: {fog: 1}}\n" + camera + "}]\n", "unknown key 'fog'"},
      {camera + ", appearance: {jpeg_quality: 101}}]\n", "'cam'.appearance.jpeg_quality"},
  };
  for (const auto& [text, key] : bad)
  {
    const auto refused = sim::parseWorld(walls + text, "bad.yaml");
    ASSERT_FALSE(refused) << text;
    EXPECT_NE(refused.error().message().find(key), std::string::npos) << refused.error().message();
  }
}

// Through the survey: the fixed camera's frames carry its optics, gains and JPEG; same seed, same frames.
TEST(Appearance, SurveyFramesAreDeterministicAndCarryTheAppearance)
{
  const std::string text =
      "surfaces: [{name: wall, rectangle: {center: [3, 0, 1], normal: [-1, 0, 0], size: [8, 8]}, texture: "
      "{pattern: checker, cell: [0.3, 0.3]}}]\nroute: {waypoints: [[0, 0], [1, 0]]}\n"
      "appearance: {xtion_rgb: {exposure: 0.5}, depth: {flying_pixels: 0.5, low_frequency_coefficient: 0.001}}\n"
      "fixed_cameras: [{name: cam, width: 320, height: 240, fx: 300, position: [0, 0, 1], look_at: [3, 0, 1], "
      "appearance: {exposure: 0.5, jpeg_quality: 50}}]\n";
  const sim::World world = parse(text);
  sim::SimulationOptions options;
  options.duration_s = 6.0;
  const auto a = sim::SurveySimulator::create(world, options), b = sim::SurveySimulator::create(world, options);
  ASSERT_TRUE(a && b);
  const cv::Mat fa = a->fixedFrame(0, 0).image, fb = b->fixedFrame(0, 0).image;
  EXPECT_EQ(cv::norm(fa, fb, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a->xtionFrame(1).depth_mm, b->xtionFrame(1).depth_mm, cv::NORM_INF), 0.0);
  const cv::Mat clean = sim::Renderer(a->world()).render(a->fixedCamera(0)).rgb;
  EXPECT_NEAR(cv::mean(fa)[1] / cv::mean(clean)[1], 0.5, 0.02);
  EXPECT_NEAR(cv::mean(a->xtionFrame(1).rgb)[1] /
                  cv::mean(sim::Renderer(a->world()).render(a->xtionCamera(a->xtionStamps()[1])).rgb)[1],
              0.5, 0.02);
}

TEST(Appearance, GeneratorIsRealisticByDefaultAndPlainOnRequest)
{
  sim::WorldGeneratorOptions options;
  options.seed = 7;
  const auto realistic = sim::generateWorld(options);
  options.realistic_appearance = false;
  const auto plain = sim::generateWorld(options);
  ASSERT_TRUE(realistic && plain);
  const sim::World& r = realistic->world;
  const sim::World& p = plain->world;
  // The same building either way.
  ASSERT_EQ(r.surfaces.size(), p.surfaces.size());
  ASSERT_EQ(r.fixed_cameras.size(), p.fixed_cameras.size());
  for (size_t k = 0; k < r.fixed_cameras.size(); ++k)
    EXPECT_TRUE(r.fixed_cameras[k].camera.pose().center().isApprox(p.fixed_cameras[k].camera.pose().center()));
  EXPECT_EQ(r.route.waypoints.size(), p.route.waypoints.size());
  EXPECT_TRUE(p.appearance.xtion_rgb.neutral());
  EXPECT_EQ(p.appearance.depth.flying_pixels, 0.0);
  EXPECT_FALSE(r.appearance.xtion_rgb.neutral());
  EXPECT_GT(r.appearance.depth.flying_pixels, 0.0);
  EXPECT_GT(r.appearance.depth.misregistration_px.norm(), 0.0);
  for (size_t k = 0; k < r.fixed_cameras.size(); ++k)
  {
    const sim::CameraAppearance& a = r.fixed_cameras[k].appearance;
    EXPECT_TRUE(p.fixed_cameras[k].appearance.neutral());
    EXPECT_GT(a.jpeg_quality, 0);
    EXPECT_GT(a.blur_sigma_px, 0.0);
    EXPECT_NE(a.exposure, r.appearance.xtion_rgb.exposure);  // each camera its own exposure
    if (k > 0)
    {
      EXPECT_NE(a.white_balance, r.fixed_cameras[k - 1].appearance.white_balance);
    }
  }
}

// ---- Materials ------------------------------------------------------------------------------------------------

namespace
{
sim::Texture brickTexture()
{
  sim::Texture t;
  t.pattern = sim::Texture::Pattern::kBricks;
  t.color = sim::Color(160, 80, 60);
  t.color2 = sim::Color(200, 196, 186);
  t.cell = Eigen::Vector2d(0.225, 0.075);
  t.joint = 0.01;
  t.seed = 11;
  return t;
}

// Brightness statistics of the texture over its units (away from joints) on a 2 m square.
struct UnitStats
{
  double unit_spread = 0.0;    // standard deviation of the per-unit mean brightness
  double inside_spread = 0.0;  // mean standard deviation inside a unit
};

UnitStats unitStats(const sim::Texture& t)
{
  std::map<std::pair<int, int>, std::vector<double>> units;
  for (double u = 0.0005; u < 2.0; u += 0.0021)
    for (double v = 0.0005; v < 2.0; v += 0.0033)
    {
      int region = 0;
      const sim::Color c = t.sample(u, v, &region);
      Eigen::Vector2i unit;
      if (t.materialRegion(u, v, &unit) == 0)
        units[{unit.x(), unit.y()}].push_back(c.mean());
    }
  std::vector<double> means;
  double inside = 0.0;
  for (const auto& [key, values] : units)
  {
    double s = 0.0, s2 = 0.0;
    for (double x : values)
      s += x, s2 += x * x;
    const double mean = s / values.size();
    means.push_back(mean);
    inside += std::sqrt(std::max(0.0, s2 / values.size() - mean * mean));
  }
  double s = 0.0, s2 = 0.0;
  for (double m : means)
    s += m, s2 += m * m;
  return {std::sqrt(std::max(0.0, s2 / means.size() - (s / means.size()) * (s / means.size()))), inside / units.size()};
}
}  // namespace

TEST(Materials, StructureIsPresentWhenOnAndAbsentWhenOff)
{
  sim::Texture t = brickTexture();
  const UnitStats plain = unitStats(t);
  EXPECT_LT(plain.unit_spread, 1e-6);
  EXPECT_LT(plain.inside_spread, 1e-6);
  t.variation = 0.15;
  const UnitStats varied = unitStats(t);
  t.speckle = 0.5;
  const UnitStats speckled = unitStats(t);
  t.pattern = sim::Texture::Pattern::kPlanks;
  t.cell = Eigen::Vector2d(1.2, 0.15);
  t.speckle = 0.0;
  t.variation = 0.0;
  t.grain = 0.8;
  const UnitStats grained = unitStats(t);
  std::printf(
      "brightness spread between / inside units: plain %.2f / %.2f, variation 0.15 %.2f / %.2f, speckle 0.5 "
      "%.2f / %.2f, planks with grain 0.8 %.2f / %.2f\n",
      plain.unit_spread, plain.inside_spread, varied.unit_spread, varied.inside_spread, speckled.unit_spread,
      speckled.inside_spread, grained.unit_spread, grained.inside_spread);
  EXPECT_GT(varied.unit_spread, 0.15 * 100 / 3);  // uniform in +-15 % of ~100 grey levels: sigma 8.7
  EXPECT_LT(varied.inside_spread, 1e-4);
  EXPECT_GT(speckled.inside_spread, 5.0);
  EXPECT_GT(grained.inside_spread, 2.5);  // streaks of up to 16 % (grain 0.8), fading: sigma about 4 grey levels
  // A lighting gradient: smooth over metres, also under the rectangles.
  sim::Texture paint;
  paint.gradient = 0.3;
  paint.rects.push_back({Eigen::Vector2d(0, 0), Eigen::Vector2d(5, 5), sim::Color(100, 100, 100)});
  int region = 0;
  double lo = 1e9, hi = 0.0, step = 0.0;
  for (double u = 0.0; u < 4.0; u += 0.01)
  {
    const double b = paint.sample(u, 1.0, &region).mean();
    if (u > 0.0)
      step = std::max(step, std::abs(b - paint.sample(u - 0.01, 1.0, &region).mean()));
    lo = std::min(lo, b);
    hi = std::max(hi, b);
  }
  std::printf("paint gradient 0.3 over 4 m: brightness %.1f .. %.1f, largest change per cm %.2f\n", lo, hi, step);
  EXPECT_GT(hi - lo, 10.0);
  EXPECT_LT(step, 1.0);
  EXPECT_EQ(region, 2);
}

// The joints are true texture edges: each listed edge separates a brick from mortar in the rendered image, and
// every course is listed.
TEST(Materials, JointsAreTrueTextureEdgesAtColourBoundaries)
{
  const std::string text =
      "lighting: {ambient: 1.0, diffuse: 0.0}\nsurfaces:\n  - name: wall\n    rectangle: {center: [2, 0, 0], "
      "normal: [-1, 0, 0], size: [1.2, 0.9]}\n    texture: {pattern: bricks, cell: [0.225, 0.075], joint: 0.01, "
      "color: [160, 80, 60], color2: [200, 196, 186], variation: 0.1, speckle: 0.3, seed: 3}\n" +
      kRoute + "fixed_cameras: []\n";
  const sim::World world = parse(text);
  const sim::ViewCamera cam = lookingAlongX();
  const sim::RenderedView view = sim::Renderer(world).render(cam);
  const std::vector<sim::TrueEdge> edges = sim::computeTrueEdges(world);
  size_t horizontal = 0, checked = 0, boundary = 0;
  const Eigen::Isometry3d camera_from_world = cam.world_from_camera.inverse();
  for (const sim::TrueEdge& e : edges)
  {
    if (e.kind != "texture")
      continue;
    horizontal += std::abs(e.start.z() - e.end.z()) < 1e-9 ? 1 : 0;
    const Eigen::Vector3d m = camera_from_world * (0.5 * (e.start + e.end));
    const Eigen::Vector3d d = camera_from_world.linear() * (e.end - e.start).normalized();
    const Eigen::Vector2d p(cam.intrinsics.fx * m.x() / m.z() + cam.intrinsics.cx,
                            cam.intrinsics.fy * m.y() / m.z() + cam.intrinsics.cy);
    const Eigen::Vector2d n(-d.y(), d.x());  // across the edge in the image (fronto-parallel wall)
    const Eigen::Vector2i a = (p + 1.2 * n).array().round().cast<int>(), b = (p - 1.2 * n).array().round().cast<int>();
    ++checked;
    boundary += view.region.at<int>(a.y(), a.x()) != view.region.at<int>(b.y(), b.x()) ? 1 : 0;
  }
  // 12 courses of 7.5 cm in 0.9 m, each with a joint (two lines); the wall's outline is not a texture edge.
  std::printf("brick wall: %zu texture edges (%zu horizontal), %zu of %zu at a region boundary in the image\n", checked,
              horizontal, boundary, checked);
  EXPECT_GE(horizontal, 2u * 11);
  EXPECT_GT(checked, horizontal + 2 * 11 * 4);  // head joints, about 5 per course
  EXPECT_EQ(boundary, checked);
}

TEST(Materials, AreDeterministicFromTheirSeedAndRefuseBadValues)
{
  auto wall = [&](const std::string& texture) {
    return "surfaces:\n  - name: wall\n    rectangle: {center: [2, 0, 0], normal: [-1, 0, 0], size: [4, 4]}\n"
           "    texture: " +
           texture + "\n" + kRoute + "fixed_cameras: []\n";
  };
  const std::string planks =
      "{pattern: planks, cell: [1.2, 0.15], joint: 0.004, grain: 0.6, variation: 0.1, "
      "gradient: 0.2, speckle: 0.1, seed: ";
  const sim::World a = parse(wall(planks + "5}")), b = parse(wall(planks + "5}")), c = parse(wall(planks + "6}"));
  const sim::ViewCamera cam = lookingAlongX();
  const cv::Mat ia = sim::Renderer(a).render(cam).rgb, ib = sim::Renderer(b).render(cam).rgb;
  EXPECT_EQ(cv::norm(ia, ib, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(ia, sim::Renderer(c).render(cam).rgb, cv::NORM_L1), 0.0);
  const std::pair<std::string, std::string> bad[] = {
      {"{pattern: tiles, cell: [0.3, 0.3], joint: 0.001}", "texture.joint"},
      {"{pattern: bricks, cell: [0.2, 0.06], joint: 0.04}", "texture.joint"},
      {"{pattern: planks, grain: 2}", "texture.grain"},
      {"{speckle: -0.1}", "texture.speckle"},
      {"{gradient: .inf}", "gradient"},
      {"{pattern: tiles, seed: -3}", "texture.seed"},
      {"{pattern: marble}", "unknown pattern 'marble'"},
  };
  for (const auto& [texture, key] : bad)
  {
    const auto refused = sim::parseWorld(wall(texture), "bad.yaml");
    ASSERT_FALSE(refused) << texture;
    EXPECT_NE(refused.error().message().find(key), std::string::npos) << refused.error().message();
  }
}

// A glossy highlight: brightest where the light's mirror direction meets the eye, smooth, and no new regions.
TEST(Materials, ShineAddsASmoothHighlightWithoutEdges)
{
  auto world = [](const std::string& shine) {
    return parse(
        "lighting: {ambient: 1.0, diffuse: 0.0, direction: [-1, 0, 0]}\nsurfaces:\n  - name: wall\n"
        "    rectangle: {center: [2, 0, 0], normal: [-1, 0, 0], size: [40, 40]}\n    texture: {color: [100, "
        "100, 100]" +
        shine + "}\n" + kRoute + "fixed_cameras: []\n");
  };
  const sim::World matte = world(""), glossy = world(", shine: 0.2");
  const sim::ViewCamera cam = lookingAlongX();
  const sim::RenderedView a = sim::Renderer(matte).render(cam), b = sim::Renderer(glossy).render(cam);
  const double centre = meanGreen(b.rgb, 320, 240, 1), corner = meanGreen(b.rgb, 636, 476, 1);
  std::printf("shine 0.2 facing the light: centre %.1f, corner %.1f (matte 100)\n", centre, corner);
  EXPECT_NEAR(meanGreen(a.rgb, 320, 240, 1), 100.0, 0.5);
  EXPECT_NEAR(centre, 100.0 + 0.2 * 255.0, 1.0);
  EXPECT_GT(corner, 100.5);
  EXPECT_LT(corner, centre - 30.0);
  EXPECT_EQ(cv::countNonZero(a.region != b.region), 0);
  EXPECT_EQ(a.antialiased_pixels, b.antialiased_pixels);
}
