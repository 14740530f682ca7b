#include "insitu_calibration/simulation/edge_sightings.h"

#include <algorithm>
#include <cmath>

#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/sensor_models.h"

namespace insitu_calibration
{
namespace simulation
{
namespace
{
struct KeyframeView
{
  ViewCamera camera;
  RenderedView view;
  cv::Mat depth_mm;  // the sensor's noise-free return (0: none)
};

// One sample point seen from a keyframe: whether it is in the image and not hidden (the rendered depth of a pixel
// in its 3x3 neighbourhood matches its own: an edge point lies on the boundary of what is drawn), and whether the
// sensor returned depth there.
struct SampleSight
{
  bool visible = false;
  bool depth = false;
  double range_m = 0.0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

SampleSight sightSample(const KeyframeView& k, const Eigen::Vector3d& point)
{
  SampleSight s;
  const Eigen::Vector3d c = k.camera.world_from_camera.inverse() * point;
  if (c.z() < 0.05)
    return s;
  const Intrinsics& in = k.camera.intrinsics;
  s.pixel = {in.fx * c.x() / c.z() + in.skew * c.y() / c.z() + in.cx, in.fy * c.y() / c.z() + in.cy};
  const int u = static_cast<int>(std::lround(s.pixel.x())), v = static_cast<int>(std::lround(s.pixel.y()));
  if (u < 1 || v < 1 || u > k.camera.width - 2 || v > k.camera.height - 2)
    return s;
  s.range_m = c.z();
  const double tolerance = 0.02 + 0.01 * c.z();
  for (int dv = -1; dv <= 1; ++dv)
    for (int du = -1; du <= 1; ++du)
    {
      const float z = k.view.depth.at<float>(v + dv, u + du);
      if (z <= 0.0f || std::abs(z - c.z()) > tolerance)
        continue;
      s.visible = true;
      s.depth = s.depth || k.depth_mm.at<uint16_t>(v + dv, u + du) > 0;
    }
  return s;
}

// Adds one keyframe's sighting of the segment to e.
void sightFrom(const KeyframeView& k, const Segment3d& segment, const SightingOptions& options, EdgeSightings* e)
{
  const int n = std::max(2, static_cast<int>(std::ceil(segment.length() / options.sample_step_m)) + 1);
  int visible = 0, depth = 0;
  double range = std::numeric_limits<double>::infinity();
  Eigen::Vector2d first = Eigen::Vector2d::Zero(), last = first;
  for (int i = 0; i < n; ++i)
  {
    const SampleSight s = sightSample(k, segment.pointAt(static_cast<double>(i) / (n - 1)));
    if (!s.visible)
      continue;
    if (visible == 0)
      first = s.pixel;
    last = s.pixel;
    ++visible;
    depth += s.depth ? 1 : 0;
    range = std::min(range, s.range_m);
  }
  if (visible < options.min_fraction * n || (last - first).norm() < options.min_image_length_px)
    return;
  ++e->in_view;
  e->nearest_range_m = std::min(e->nearest_range_m, range);
  if (depth >= options.min_fraction * n)
    ++e->with_depth;
}
}  // namespace

std::vector<EdgeSightings> sightSegments(const World& world, const std::vector<Segment3d>& segments,
                                         const std::vector<Eigen::Isometry3d>& rgb_poses,
                                         const SightingOptions& options)
{
  std::vector<EdgeSightings> sightings(segments.size());
  const Renderer renderer(world);
  RenderOptions render;
  render.supersampling = 1;
  render.color = false;
  for (const Eigen::Isometry3d& pose : rgb_poses)
  {
    KeyframeView k;
    k.camera.width = world.xtion.width;
    k.camera.height = world.xtion.height;
    k.camera.intrinsics = world.xtion.intrinsics;
    k.camera.world_from_camera = pose;
    k.view = renderer.render(k.camera, render);
    k.depth_mm = simulateXtionDepth(k.view, world, k.camera, world.xtion.depth, false, 0);
    for (size_t i = 0; i < segments.size(); ++i)
      sightFrom(k, segments[i], options, &sightings[i]);
  }
  return sightings;
}

}  // namespace simulation
}  // namespace insitu_calibration
