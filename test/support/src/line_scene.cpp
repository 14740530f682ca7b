#include "insitu_calibration/test_support/line_scene.h"

#include <cmath>
#include <limits>

#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace
{
void addBox(LineScene& scene, const Eigen::Vector3d& corner, const Eigen::Vector3d& size, const double greys[5])
{
  const Eigen::Vector3d x(size.x(), 0, 0), y(0, size.y(), 0), z(0, 0, size.z());
  scene.quads.push_back({corner + z, x, y, greys[0]});  // top
  scene.quads.push_back({corner, x, z, greys[1]});      // y = min
  scene.quads.push_back({corner + y, x, z, greys[2]});  // y = max
  scene.quads.push_back({corner, y, z, greys[3]});      // x = min
  scene.quads.push_back({corner + x, y, z, greys[4]});  // x = max
}

}  // namespace

std::vector<Segment3d> LineScene::edges() const
{
  std::vector<Segment3d> out;
  for (const auto& q : quads)
  {
    const Eigen::Vector3d p00 = q.origin, p10 = q.origin + q.u, p01 = q.origin + q.v, p11 = q.origin + q.u + q.v;
    out.push_back({p00, p10});
    out.push_back({p10, p11});
    out.push_back({p11, p01});
    out.push_back({p01, p00});
  }
  return out;
}

LineScene makeRoomScene(std::mt19937& rng)
{
  std::uniform_real_distribution<double> jitter(-12.0, 12.0);
  auto g = [&](double base) { return std::clamp(base + jitter(rng), 5.0, 250.0); };
  const double lx = 6.0, ly = 5.0, lz = 2.7;
  LineScene s;
  s.quads.push_back({{0, 0, 0}, {lx, 0, 0}, {0, ly, 0}, g(70)});    // floor
  s.quads.push_back({{0, 0, lz}, {lx, 0, 0}, {0, ly, 0}, g(235)});  // ceiling
  s.quads.push_back({{0, 0, 0}, {lx, 0, 0}, {0, 0, lz}, g(185)});   // wall y = 0
  s.quads.push_back({{0, ly, 0}, {lx, 0, 0}, {0, 0, lz}, g(150)});  // wall y = ly
  s.quads.push_back({{0, 0, 0}, {0, ly, 0}, {0, 0, lz}, g(205)});   // wall x = 0
  s.quads.push_back({{lx, 0, 0}, {0, ly, 0}, {0, 0, lz}, g(125)});  // wall x = lx
  const double e = 0.002;  // decorations stand 2 mm off their wall (flush, but no z-fighting)
  // Doors.
  s.quads.push_back({{1.0, e, 0}, {0.9, 0, 0}, {0, 0, 2.05}, g(60)});
  s.quads.push_back({{lx - e, 2.0, 0}, {0, 0.9, 0}, {0, 0, 2.05}, g(40)});
  s.quads.push_back({{e, 3.6, 0}, {0, 0.9, 0}, {0, 0, 2.05}, g(95)});
  // Posters and windows.
  s.quads.push_back({{2.2, ly - e, 1.0}, {1.2, 0, 0}, {0, 0, 0.8}, g(40)});
  s.quads.push_back({{4.0, ly - e, 1.2}, {1.0, 0, 0}, {0, 0, 1.0}, g(245)});
  s.quads.push_back({{e, 1.2, 0.9}, {0, 1.5, 0}, {0, 0, 1.0}, g(90)});
  s.quads.push_back({{3.0, e, 1.1}, {1.4, 0, 0}, {0, 0, 0.9}, g(250)});
  s.quads.push_back({{lx - e, 0.5, 1.0}, {0, 1.0, 0}, {0, 0, 0.7}, g(230)});
  // Skirting boards.
  s.quads.push_back({{0, ly - e, 0}, {lx, 0, 0}, {0, 0, 0.12}, g(30)});
  s.quads.push_back({{lx - e, 3.0, 0}, {0, 2.0, 0}, {0, 0, 0.12}, g(250)});
  // Boxes on the floor (depth discontinuities).
  const double box1[5] = {g(225), g(110), g(45), g(160), g(25)};
  addBox(s, {1.2, 1.0, 0.0}, {0.8, 0.6, 0.7}, box1);
  const double box2[5] = {g(30), g(200), g(95), g(240), g(140)};
  addBox(s, {4.1, 3.2, 0.0}, {0.6, 0.9, 1.0}, box2);
  const double box3[5] = {g(170), g(60), g(250), g(20), g(210)};
  addBox(s, {3.3, 0.7, 0.0}, {0.5, 0.5, 0.45}, box3);
  return s;
}

namespace
{
// The scene as a simulator world: one solid-grey surface per quad, lit evenly so that each shows its own grey.
simulation::World toWorld(const LineScene& scene)
{
  simulation::World world;
  world.name = "line scene";
  world.lighting.ambient = 1.0;
  world.lighting.diffuse = 0.0;
  world.surfaces.reserve(scene.quads.size());
  for (size_t i = 0; i < scene.quads.size(); ++i)
  {
    const SceneQuad& q = scene.quads[i];
    simulation::Surface surface;
    surface.name = "quad " + std::to_string(i);
    surface.rings = {{q.origin, q.origin + q.u, q.origin + q.u + q.v, q.origin + q.v}};
    const float grey = static_cast<float>(q.grey);
    surface.texture.color = simulation::Color(grey, grey, grey);
    const Status finalized = simulation::finalizeSurface(surface);
    if (!finalized)  // the scenes are built in code: a degenerate quad is a bug in the caller
      throw std::invalid_argument("line scene " + surface.name + ": " + finalized.error().message());
    world.surfaces.push_back(std::move(surface));
  }
  return world;
}

simulation::RenderedView renderView(const LineScene& scene, const CameraModel& camera, int width, int height,
                                    int supersampling, bool color)
{
  const simulation::World world = toWorld(scene);
  const simulation::Renderer renderer(world);
  simulation::RenderOptions options;
  options.supersampling = supersampling;
  options.color = color;
  return renderer.render(simulation::ViewCamera::fromModel(camera, width, height), options);
}
}  // namespace

cv::Mat renderGrey(const LineScene& scene, const CameraModel& camera, int width, int height,
                   const LineSceneRenderOptions& options, std::mt19937& rng)
{
  const simulation::RenderedView view = renderView(scene, camera, width, height, options.supersampling, true);
  cv::Mat grey;
  cv::extractChannel(view.rgb, grey, 0);
  grey.convertTo(grey, CV_32F);
  if (options.blur_sigma_px > 0.0)
    cv::GaussianBlur(grey, grey, cv::Size(), options.blur_sigma_px, options.blur_sigma_px, cv::BORDER_REPLICATE);
  if (options.noise_sigma > 0.0)
  {
    std::normal_distribution<double> noise(0.0, options.noise_sigma);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        grey.at<float>(y, x) += static_cast<float>(noise(rng));
  }
  cv::Mat out;
  grey.convertTo(out, CV_8U);  // rounds and saturates
  return out;
}

cv::Mat renderDepth(const LineScene& scene, const CameraModel& camera, int width, int height)
{
  const simulation::RenderedView view = renderView(scene, camera, width, height, 1, false);
  cv::Mat depth = view.depth.clone();
  depth.setTo(std::numeric_limits<float>::quiet_NaN(), view.surface < 0);
  return depth;
}

cv::Mat makeSensorDepth(const cv::Mat& depth_m, double k_per_m, bool as_millimetres, std::mt19937& rng)
{
  std::normal_distribution<double> unit(0.0, 1.0);
  cv::Mat out(depth_m.size(), as_millimetres ? CV_16UC1 : CV_32FC1);
  for (int y = 0; y < depth_m.rows; ++y)
  {
    for (int x = 0; x < depth_m.cols; ++x)
    {
      const float z = depth_m.at<float>(y, x);
      const bool valid = std::isfinite(z) && z > 0.0f;
      const double noisy = valid ? z + k_per_m * z * z * unit(rng) : 0.0;
      if (as_millimetres)
        out.at<uint16_t>(y, x) =
            valid ? static_cast<uint16_t>(std::clamp(std::lround(noisy * 1000.0), 0L, 65535L)) : uint16_t(0);
      else
        out.at<float>(y, x) = valid ? static_cast<float>(noisy) : std::numeric_limits<float>::quiet_NaN();
    }
  }
  return out;
}

}  // namespace insitu_calibration
