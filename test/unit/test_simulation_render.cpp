// The survey simulator's images against the ground truth: the rasteriser against the ray caster, depth that
// back-projects onto the world's surfaces, true 3D edges that fall on the fixed cameras' gradient maxima,
// anti-aliasing coverage, the sensor noise models, and determinism.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/simulation/random.h"
#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/sensor_models.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/true_edges.h"

namespace sim = insitu_calibration::simulation;
namespace ic = insitu_calibration;

namespace
{
const std::string kDefaultWorld = std::string(INSITU_SOURCE_DIR) + "/config/worlds/waiting_room.yaml";

sim::World loadDefaultWorld()
{
  auto world = sim::loadWorldFile(kDefaultWorld);
  EXPECT_TRUE(world) << world.error().describe();
  return std::move(*world);
}

double median(std::vector<double> v)
{
  if (v.empty())
    return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double percentile(std::vector<double> v, double p)
{
  std::sort(v.begin(), v.end());
  return v.empty() ? std::numeric_limits<double>::quiet_NaN() : v[static_cast<size_t>(p * (v.size() - 1))];
}

float bilinear(const cv::Mat& m, double x, double y)
{
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  auto at = [&](int yy, int xx) { return m.at<float>(yy, xx); };
  return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
         fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1));
}

// A world of one textured wall facing the camera at the origin (looking along +x of the map).
sim::World wallWorld(double distance, const std::string& texture = "{color: [200, 200, 200]}")
{
  const std::string d = std::to_string(distance);
  const std::string text = "surfaces:\n  - name: wall\n    rectangle: {center: [" + d +
                           ", 0, 0], normal: [-1, 0, 0], size: [40, 40]}\n    texture: " + texture +
                           "\nroute: {waypoints: [[0, 0], [1, 0]]}\nfixed_cameras: []\n";
  auto world = sim::parseWorld(text, "wall.yaml");
  EXPECT_TRUE(world) << world.error().describe();
  return std::move(*world);
}

sim::ViewCamera lookingAlongX(int width = 640, int height = 480, double f = 570.0)
{
  sim::ViewCamera cam;
  cam.width = width;
  cam.height = height;
  cam.intrinsics = {f, f, 0.0, (width - 1) / 2.0, (height - 1) / 2.0};
  Eigen::Matrix3d r;
  r.col(0) = -Eigen::Vector3d::UnitY();
  r.col(1) = -Eigen::Vector3d::UnitZ();
  r.col(2) = Eigen::Vector3d::UnitX();
  cam.world_from_camera.linear() = r;
  return cam;
}
}  // namespace

// The scanline rasteriser (pin-hole views) and the exact ray caster (used for distorted views) agree.
TEST(Renderer, RasterizerMatchesRayCaster)
{
  const sim::World world = loadDefaultWorld();
  auto survey = sim::SurveySimulator::create(world, {});
  ASSERT_TRUE(survey);
  for (const double t : {0.0, 7.3, 14.1, 23.9, 33.3})
  {
    const sim::ViewCamera cam = survey->xtionCamera(static_cast<int64_t>(t * 1e9));
    sim::RenderOptions raster, ray;
    ray.ray_cast = true;
    const sim::RenderedView a = survey->renderer().render(cam, raster);
    const sim::RenderedView b = survey->renderer().render(cam, ray);
    size_t same = 0, total = 0;
    double worst_depth = 0.0;
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x)
      {
        ++total;
        if (a.surface.at<int>(y, x) != b.surface.at<int>(y, x))
          continue;
        ++same;
        const double za = a.depth.at<float>(y, x), zb = b.depth.at<float>(y, x);
        worst_depth = std::max(worst_depth, std::abs(za - zb) / std::max(zb, 1e-3));
      }
    EXPECT_GT(static_cast<double>(same) / total, 0.999) << "t = " << t;
    EXPECT_LT(worst_depth, 1e-5) << "t = " << t;
    EXPECT_GT(a.antialiased_pixels, 1000u);
  }
}

// A depth pixel back-projected with the Xtion's intrinsics and the transforms that go into /tf and /tf_static lands
// on the world's surfaces (before noise: median error under 1 mm).
TEST(XtionDepth, BackProjectsOntoTheSurfaces)
{
  sim::SimulationOptions options;
  options.depth_noise = false;
  options.duration_s = 40.0;
  auto survey = sim::SurveySimulator::create(loadDefaultWorld(), options);
  ASSERT_TRUE(survey);
  const sim::World& world = survey->world();
  const ic::Intrinsics& k = world.xtion.intrinsics;
  std::vector<double> errors;
  size_t returns = 0, pixels = 0;
  for (const int frame : {0, 37, 81, 122, 166, 199})
  {
    const sim::XtionFrame f = survey->xtionFrame(frame);
    // map -> odom -> base_link (tf) and base_link -> camera_link -> camera_rgb_frame -> optical (tf_static).
    Eigen::Isometry3d map_from_optical = Eigen::Isometry3d::Identity();
    for (const auto& t : survey->dynamicTransforms(f.stamp_ns))
      map_from_optical = map_from_optical * t.transform;
    for (const auto& t : survey->staticTransforms())
      if (t.child == "camera_link" || t.child == "camera_rgb_frame" || t.child == "camera_rgb_optical_frame")
        map_from_optical = map_from_optical * t.transform;
    EXPECT_LT((map_from_optical.matrix() - f.map_from_optical.matrix()).norm(), 1e-12);
    for (int y = 1; y < f.depth_mm.rows; y += 6)
      for (int x = 2; x < f.depth_mm.cols; x += 6)
      {
        ++pixels;
        const uint16_t mm = f.depth_mm.at<uint16_t>(y, x);
        if (mm == 0)
          continue;
        ++returns;
        const double z = mm * 1e-3;
        const Eigen::Vector3d xc(z * (x - k.cx) / k.fx, z * (y - k.cy) / k.fy, z);
        const Eigen::Vector3d p = map_from_optical * xc;
        double d = 1e9;
        for (const auto& s : world.surfaces)
          d = std::min(d, s.distance(p));
        errors.push_back(d);
      }
  }
  const double med = median(errors);
  std::printf("depth back-projection: %zu returns of %zu pixels, median %.3f mm, 95th percentile %.3f mm\n", returns,
              pixels, 1e3 * med, 1e3 * percentile(errors, 0.95));
  EXPECT_GT(returns, pixels / 3);
  EXPECT_LT(med, 1e-3);
}

// The depth noise has sigma 1.4e-3 z^2 (the Gaussian and the disparity quantisation together) and almost no bias.
// The wall is slanted so that its depth spans many disparity steps: the quantisation error of one depth is fixed, the
// model describes it over all depths.
TEST(XtionDepth, NoiseFollowsTheModel)
{
  const sim::ViewCamera cam = lookingAlongX();
  const sim::DepthSensorConfig config;
  for (const double z0 : {1.0, 2.0, 3.0, 4.0})
  {
    const std::string d = std::to_string(z0);
    const std::string text = "surfaces:\n  - name: wall\n    rectangle: {center: [" + d +
                             ", 0, 0], normal: [-1, 0.5, 0], size: [40, 40]}\nroute: {waypoints: [[0, 0], [1, "
                             "0]]}\nfixed_cameras: []\n";
    const auto world = sim::parseWorld(text, "slanted.yaml");
    ASSERT_TRUE(world) << world.error().describe();
    const sim::Renderer renderer(*world);
    sim::RenderOptions ro;
    ro.color = false;
    const sim::RenderedView view = renderer.render(cam, ro);
    double sum = 0.0, sum2 = 0.0;
    size_t n = 0;
    for (uint64_t seed = 1; seed <= 3; ++seed)
    {
      const cv::Mat depth = sim::simulateXtionDepth(view, *world, cam, config, true, seed);
      for (int y = 0; y < depth.rows; ++y)
        for (int x = 0; x < depth.cols; ++x)
        {
          const double truth = view.depth.at<float>(y, x);
          if (depth.at<uint16_t>(y, x) == 0)
            continue;
          const double e = (depth.at<uint16_t>(y, x) * 1e-3 - truth) / (truth * truth);  // in units of z^2
          sum += e;
          sum2 += e * e;
          ++n;
        }
    }
    const double mean = sum / n;
    const double coefficient = std::sqrt(sum2 / n - mean * mean);
    std::printf("depth noise around %.0f m: sigma %.3e z^2 (model %.3e z^2), mean %+.1e z^2\n", z0, coefficient,
                config.sigma_coefficient, mean);
    EXPECT_GT(n, 3u * 640 * 480 / 2);  // at 4 m part of the wall is beyond the 5 m range
    EXPECT_NEAR(coefficient / config.sigma_coefficient, 1.0, 0.05) << "z = " << z0;
    EXPECT_LT(std::abs(mean), 0.05 * config.sigma_coefficient) << "z = " << z0;
  }
  const sim::World far = wallWorld(5.5);
  // Beyond the maximum range: nothing.
  const sim::Renderer renderer(far);
  const sim::RenderedView view = renderer.render(cam);
  const cv::Mat depth = sim::simulateXtionDepth(view, far, cam, config, true, 1);
  EXPECT_EQ(cv::countNonZero(depth), 0);
}

// No return where the ray meets the surface at more than max_incidence_deg: a floor seen from 1 m high.
TEST(XtionDepth, NoReturnAtGrazingAngles)
{
  const std::string text = R"(
surfaces: [{name: floor, polygon: [[-50, -50, 0], [50, -50, 0], [50, 50, 0], [-50, 50, 0]]}]
route: {waypoints: [[0, 0], [1, 0]]}
fixed_cameras: []
)";
  auto world = sim::parseWorld(text, "floor.yaml");
  ASSERT_TRUE(world);
  sim::ViewCamera cam = lookingAlongX();
  cam.world_from_camera.translation() = Eigen::Vector3d(0, 0, 1.0);
  // Tilt down 20 degrees.
  cam.world_from_camera.linear() = Eigen::AngleAxisd(20.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix() *
                                   cam.world_from_camera.linear();
  const sim::Renderer renderer(*world);
  const sim::RenderedView view = renderer.render(cam);
  sim::DepthSensorConfig config;
  config.max_range_m = 60.0;
  const cv::Mat depth = sim::simulateXtionDepth(view, *world, cam, config, false, 1);
  size_t checked = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; x += 7)
    {
      if (view.surface.at<int>(y, x) < 0)
        continue;
      const Eigen::Vector3d ray = (cam.world_from_camera.linear() * *cam.ray(x, y)).normalized();
      const double incidence = std::acos(std::abs(ray.z())) * 180.0 / M_PI;
      if (std::abs(incidence - config.max_incidence_deg) < 0.2)
        continue;
      ++checked;
      EXPECT_EQ(depth.at<uint16_t>(y, x) == 0, incidence > config.max_incidence_deg) << x << "," << y;
    }
  EXPECT_GT(checked, 5000u);
}

// Anti-aliasing: a vertical black/white texture edge at a known sub-pixel position gives the coverage of the n x n
// samples in the pixels it crosses.
TEST(Renderer, AntiAliasingGivesCoverage)
{
  const int n = 4;
  const double f = 570.0;
  for (const double edge_px : {300.1, 300.3, 300.5, 300.8})
  {
    // The wall at 2 m; its texture changes colour at the map y whose image is x = edge_px.
    const sim::ViewCamera cam = lookingAlongX(640, 480, f);
    const double y_map = -(edge_px - cam.intrinsics.cx) / f * 2.0;
    // Rectangle u axis: up x normal = z x (-x) = -y; u = 0 at y = +20.
    const double u = 20.0 - y_map;
    const std::string texture =
        "{color: [0, 0, 0], rects: [{min: [" + std::to_string(u) + ", 0], max: [40, 40], color: [255, 255, 255]}]}";
    const sim::World world = wallWorld(2.0, texture);
    const sim::Renderer renderer(world);
    sim::RenderOptions ro;
    ro.supersampling = n;
    const sim::RenderedView view = renderer.render(cam, ro);
    const float shade = renderer.shade(0);
    for (int x = 297; x <= 303; ++x)
    {
      // Samples at x + (i + 0.5) / n - 0.5: white where beyond the edge.
      int covered = 0;
      for (int i = 0; i < n; ++i)
        covered += x + (i + 0.5) / n - 0.5 >= edge_px;
      const double expected = 255.0 * shade * covered / n;
      EXPECT_NEAR(view.rgb.at<cv::Vec3b>(240, x)[0], expected, 1.0) << "edge " << edge_px << " pixel " << x;
    }
  }
}

namespace
{
// Central-difference gradient magnitude of an RGB image's grey values.
cv::Mat gradientMagnitude(const cv::Mat& rgb)
{
  cv::Mat grey, g;
  cv::cvtColor(rgb, grey, cv::COLOR_RGB2GRAY);
  grey.convertTo(g, CV_32F);
  cv::Mat mag(g.size(), CV_32F, cv::Scalar(0));
  for (int y = 1; y + 1 < g.rows; ++y)
    for (int x = 1; x + 1 < g.cols; ++x)
    {
      const float gx = 0.5f * (g.at<float>(y, x + 1) - g.at<float>(y, x - 1));
      const float gy = 0.5f * (g.at<float>(y + 1, x) - g.at<float>(y - 1, x));
      mag.at<float>(y, x) = std::sqrt(gx * gx + gy * gy);
    }
  return mag;
}

// Whether the projected edge point p (tangent t, normal n) is a clean edge of the view (one region on each side
// along 3 px, away from junctions) where the camera sees the 3D point at depth z (not hidden behind something).
bool cleanVisibleEdge(const sim::RenderedView& view, const Eigen::Vector2d& p, const Eigen::Vector2d& t,
                      const Eigen::Vector2d& n, double z)
{
  auto key = [&](const Eigen::Vector2d& q) {
    return view.region.at<int>(static_cast<int>(std::lround(q.y())), static_cast<int>(std::lround(q.x())));
  };
  bool clean = true;
  const int a = key(p - 2.5 * n), b = key(p + 2.5 * n);
  clean &= a != b;
  for (const double s : {-2.5, 0.0, 2.5})
    for (const double d : {1.5, 2.5, 3.5})
      clean &= key(p + s * t - d * n) == a && key(p + s * t + d * n) == b;
  if (!clean)
    return false;
  bool visible = false;
  for (const double d : {-1.5, 0.0, 1.5})
  {
    const Eigen::Vector2d q = p + d * n;
    const float zr = view.depth.at<float>(static_cast<int>(std::lround(q.y())), static_cast<int>(std::lround(q.x())));
    visible |= std::abs(zr - z) < 0.01 * z;
  }
  return visible;
}

// The gradient maximum along the normal n through p, refined by a parabola: its offset from p (px).
double gradientMaximumOffset(const cv::Mat& mag, const Eigen::Vector2d& p, const Eigen::Vector2d& n)
{
  double best = -1.0;
  double best_s = 0.0;
  for (double s = -2.0; s <= 2.0; s += 0.25)
  {
    const float v = bilinear(mag, p.x() + s * n.x(), p.y() + s * n.y());
    if (v > best)
    {
      best = v;
      best_s = s;
    }
  }
  const double gm = bilinear(mag, p.x() + (best_s - 1) * n.x(), p.y() + (best_s - 1) * n.y());
  const double gp = bilinear(mag, p.x() + (best_s + 1) * n.x(), p.y() + (best_s + 1) * n.y());
  const double den = gm - 2 * best + gp;
  return den < 0 ? best_s + 0.5 * (gm - gp) / den : best_s;
}

// |gradient maximum - projected true edge| at points along every true edge that the camera sees cleanly.
std::vector<double> edgeOffsets(const sim::SimulatedFixedCamera& fc, const std::vector<sim::TrueEdge>& edges,
                                const sim::RenderedView& view, const cv::Mat& mag)
{
  const ic::CameraModel& model = fc.camera;
  std::vector<double> offsets;
  for (const sim::TrueEdge& e : edges)
  {
    const auto pa = model.project(e.start), pb = model.project(e.end);
    const double length = pa && pb ? (*pa - *pb).norm() : 200.0;
    const int samples = static_cast<int>(std::clamp(length / 4.0, 2.0, 400.0));
    const Eigen::Vector3d dir = (e.end - e.start).normalized();
    for (int i = 1; i < samples; ++i)
    {
      const Eigen::Vector3d X = e.start + (e.end - e.start) * (static_cast<double>(i) / samples);
      const auto p = model.project(X);
      const auto p1 = model.project(X + 0.005 * dir), p0 = model.project(X - 0.005 * dir);
      if (!p || !p1 || !p0)
        continue;
      if (p->x() < 8 || p->y() < 8 || p->x() > fc.width - 9 || p->y() > fc.height - 9)
        continue;
      const Eigen::Vector2d t = (*p1 - *p0).normalized();
      const Eigen::Vector2d n(-t.y(), t.x());
      if (cleanVisibleEdge(view, *p, t, n, model.toCamera(X).z()))
        offsets.push_back(std::abs(gradientMaximumOffset(mag, *p, n)));
    }
  }
  return offsets;
}
}  // namespace

// The world's true 3D edges projected into each fixed camera with the true K, lambda and pose fall on the image's
// gradient maxima (median under 0.5 px), in the clean image and in a noisy frame.
TEST(FixedCameras, TrueEdgesFallOnGradientMaxima)
{
  auto survey = sim::SurveySimulator::create(loadDefaultWorld(), {});
  ASSERT_TRUE(survey);
  const sim::World& world = survey->world();
  const std::vector<sim::TrueEdge> edges = sim::computeTrueEdges(world);
  for (size_t c = 0; c < world.fixed_cameras.size(); ++c)
  {
    const sim::SimulatedFixedCamera& fc = world.fixed_cameras[c];
    sim::RenderOptions ro;
    ro.supersampling = fc.supersampling;
    const sim::ViewCamera cam = survey->fixedCamera(static_cast<int>(c));
    const sim::RenderedView view = survey->renderer().render(cam, ro);
    const cv::Mat noisy = survey->fixedFrame(static_cast<int>(c), 0).image;
    for (const bool with_noise : {false, true})
    {
      const std::vector<double> offsets =
          edgeOffsets(fc, edges, view, gradientMagnitude(with_noise ? noisy : view.rgb));
      const double med = median(offsets);
      std::printf(
          "%s %s: %zu edge points, |gradient maximum - projected true edge| median %.3f px, 90th percentile "
          "%.3f px\n",
          fc.name.c_str(), with_noise ? "noisy" : "clean", offsets.size(), med, percentile(offsets, 0.9));
      EXPECT_GT(offsets.size(), 300u) << fc.name;
      EXPECT_LT(med, 0.5) << fc.name << (with_noise ? " noisy" : " clean");
    }
  }
}

TEST(ImageNoise, FollowsTheModel)
{
  const sim::ImageNoiseConfig noise{1.5, 0.02};
  for (const int level : {0, 60, 128, 250})
  {
    const cv::Mat clean(400, 400, CV_8UC3, cv::Scalar(level, level, level));
    const cv::Mat noisy = sim::addImageNoise(clean, noise, 7);
    cv::Mat diff;
    noisy.convertTo(diff, CV_64F);
    diff -= cv::Scalar(level, level, level);
    cv::Scalar mean, sd;
    cv::meanStdDev(diff.reshape(1), mean, sd);
    const double expected = std::sqrt(1.5 * 1.5 + 0.02 * level + 1.0 / 12.0);  // + rounding
    if (level > 10 && level < 245)
    {
      EXPECT_NEAR(sd[0] / expected, 1.0, 0.05) << level;
      EXPECT_NEAR(mean[0], 0.0, 0.05) << level;
    }
  }
}

TEST(Random, StreamsAreReproducibleAndDistinct)
{
  sim::FastRandom a(sim::streamSeed(5, 1, 2, 3)), b(sim::streamSeed(5, 1, 2, 3)), c(sim::streamSeed(5, 1, 2, 4));
  bool differ = false;
  double sum = 0, sum2 = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i)
  {
    const float ga = a.gaussian(), gb = b.gaussian(), gc = c.gaussian();
    EXPECT_EQ(ga, gb);
    differ |= ga != gc;
    sum += ga;
    sum2 += ga * ga;
  }
  EXPECT_TRUE(differ);
  EXPECT_NEAR(sum / n, 0.0, 0.01);
  EXPECT_NEAR(sum2 / n, 1.0, 0.01);
}

// Same seed, same frames; another seed, other noise on the same clean images.
TEST(Survey, IsDeterministic)
{
  sim::SimulationOptions options;
  options.duration_s = 2.0;
  options.seed = 42;
  options.odom_drift = true;
  auto s1 = sim::SurveySimulator::create(loadDefaultWorld(), options);
  auto s2 = sim::SurveySimulator::create(loadDefaultWorld(), options);
  options.seed = 43;
  auto s3 = sim::SurveySimulator::create(loadDefaultWorld(), options);
  ASSERT_TRUE(s1 && s2 && s3);
  ASSERT_EQ(s1->events().size(), s2->events().size());
  auto same = [](const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
  };
  // s2 in order, s1 out of order: the noise of a frame does not depend on which frames were made before.
  std::map<int, sim::XtionFrame> in_order;
  for (const int i : {2, 5, 7})
    in_order[i] = s2->xtionFrame(i);
  for (const int i : {7, 2, 5})
  {
    const sim::XtionFrame a = s1->xtionFrame(i), b = in_order[i];
    EXPECT_TRUE(same(a.rgb, b.rgb));
    EXPECT_TRUE(same(a.depth_mm, b.depth_mm));
    EXPECT_FALSE(same(a.depth_mm, s3->xtionFrame(i).depth_mm));
    EXPECT_TRUE(same(a.rgb, s3->xtionFrame(i).rgb));  // no noise on the Xtion RGB by default
  }
  for (size_t c = 0; c < s1->world().fixed_cameras.size(); ++c)
  {
    const cv::Mat a = s1->fixedFrame(static_cast<int>(c), 0).image;
    EXPECT_TRUE(same(a, s2->fixedFrame(static_cast<int>(c), 0).image));
    EXPECT_FALSE(same(a, s3->fixedFrame(static_cast<int>(c), 0).image));
  }
  for (const auto& e : s1->events())
  {
    if (e.kind != sim::SurveyEventKind::kTf)
      continue;
    const auto a = s1->dynamicTransforms(e.stamp_ns), b = s2->dynamicTransforms(e.stamp_ns);
    for (size_t k = 0; k < a.size(); ++k)
      EXPECT_EQ(a[k].transform.matrix(), b[k].transform.matrix());
    // With drift, map -> odom -> base_link is still the true pose.
    EXPECT_LT(((a[0].transform * a[1].transform).matrix() - s1->mapFromBase(e.stamp_ns).matrix()).norm(), 1e-12);
  }
}

TEST(Survey, TimelineHasTheStatedRates)
{
  sim::SimulationOptions options;  // 40 s at 5 Hz
  auto s = sim::SurveySimulator::create(loadDefaultWorld(), options);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->xtionFrameCount(), 200u);
  EXPECT_DOUBLE_EQ(s->tfRateHz(), 20.0);
  std::map<int, size_t> count;
  int64_t last = -1;
  for (const auto& e : s->events())
  {
    EXPECT_GE(e.stamp_ns, last);
    last = e.stamp_ns;
    if (e.kind == sim::SurveyEventKind::kXtion)
    {
      EXPECT_EQ(e.stamp_ns % 200000000, 0);  // every RGB-D frame has a tf sample at its stamp
    }
    count[static_cast<int>(e.kind) * 100 + e.camera]++;
  }
  EXPECT_EQ(count[static_cast<int>(sim::SurveyEventKind::kStaticTf) * 100 - 1], 1u);
  EXPECT_EQ(count[static_cast<int>(sim::SurveyEventKind::kTf) * 100 - 1], 801u);
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(count[static_cast<int>(sim::SurveyEventKind::kFixed) * 100 + c], 8u);  // 0.2 Hz for 40 s
  const auto ground_truth = s->groundTruth(0);
  EXPECT_EQ(ground_truth.camera_name, s->world().fixed_cameras[0].name);
  EXPECT_LT((ground_truth.camera.projectionMatrix() - s->world().fixed_cameras[0].camera.projectionMatrix()).norm(),
            1e-12);
}

TEST(TrueEdges, BoxEdgesAreMergedAndClassified)
{
  const std::string text = R"(
surfaces:
  - {name: floor, polygon: [[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0]]}
  - name: box
    box: {min: [1, 1, 0], max: [2, 2, 1]}
    texture: {pattern: checker, cell: 0.5, rects: [{min: [0.25, 0.25], max: [0.75, 0.75], color: [0, 0, 0]}]}
route: {waypoints: [[0, 0], [1, 0]]}
fixed_cameras: []
)";
  auto world = sim::parseWorld(text, "box.yaml");
  ASSERT_TRUE(world) << world.error().describe();
  const auto edges = sim::computeTrueEdges(*world);
  std::map<std::string, int> kinds;
  for (const auto& e : edges)
    kinds[e.kind]++;
  EXPECT_EQ(kinds["crease"], 8);   // 4 vertical + 4 top edges of the box
  EXPECT_EQ(kinds["outline"], 8);  // the floor's 4 and the box's 4 bottom edges
  // Texture: per face, the checker's middle lines u = 0.5 and v = 0.5, except under the rectangle (which covers
  // (0.25, 0.75)^2, so each middle line keeps 2 pieces of 0.25 m), plus the rectangle's 4 sides: 5 faces x 8.
  EXPECT_EQ(kinds["texture"], 40);
  std::map<long, int> lengths_mm;
  for (const auto& e : edges)
    if (e.kind == "texture")
      lengths_mm[std::lround(1000.0 * (e.end - e.start).norm())]++;
  EXPECT_EQ(lengths_mm[250], 20);  // checker pieces
  EXPECT_EQ(lengths_mm[500], 20);  // rectangle sides
  const std::string path = ::testing::TempDir() + "/edges_test.yaml";
  ASSERT_TRUE(sim::saveTrueEdges(path, edges, "box"));
  const auto loaded = sim::loadTrueEdges(path);
  ASSERT_TRUE(loaded) << loaded.error().describe();
  ASSERT_EQ(loaded->size(), edges.size());
  EXPECT_LT(((*loaded)[5].start - edges[5].start).norm(), 1e-9);
  EXPECT_EQ((*loaded)[5].surfaces, edges[5].surfaces);
}
