#include <Eigen/Geometry>

#include "insitu_calibration/test_support/synthetic_lines.h"
#include "insitu_calibration/geometry/optical_frame.h"

#include <cmath>

namespace insitu_calibration
{
namespace
{
constexpr double kDegToRad = M_PI / 180.0;

bool insideImage(const Eigen::Vector2d& p, int width, int height, double margin)
{
  return p.x() >= margin && p.y() >= margin && p.x() <= width - 1 - margin && p.y() <= height - 1 - margin;
}

Eigen::Vector3d randomUnitVector(std::mt19937& rng)
{
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector3d v;
  do
  {
    v = Eigen::Vector3d(n(rng), n(rng), n(rng));
  } while (v.norm() < 1e-6);
  return v.normalized();
}
}  // namespace

CameraModel randomCamera(const SyntheticCameraOptions& options, std::mt19937& rng)
{
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };

  Intrinsics in;
  in.fx = uniform(options.focal_min_px, options.focal_max_px);
  in.fy = in.fx * (1.0 + uniform(-options.aspect_jitter, options.aspect_jitter));
  in.skew = 0.0;
  in.cx = 0.5 * (options.image_width - 1) + uniform(-options.principal_jitter_px, options.principal_jitter_px);
  in.cy = 0.5 * (options.image_height - 1) + uniform(-options.principal_jitter_px, options.principal_jitter_px);

  DivisionModel distortion;
  distortion.center = in.principalPoint();
  distortion.lambda = lambdaForCornerDisplacement(distortion.center, options.image_width, options.image_height,
                                                  options.corner_displacement_px);

  // Mounted near a room corner at the origin, looking diagonally into the room and down.
  const double yaw = uniform(25.0, 65.0) * kDegToRad;
  const double tilt = uniform(options.tilt_min_deg, options.tilt_max_deg) * kDegToRad;
  const Eigen::Vector3d position(uniform(0.2, 0.6), uniform(0.2, 0.6), options.height_m);
  const Eigen::Vector3d forward(std::cos(tilt) * std::cos(yaw), std::cos(tilt) * std::sin(yaw), -std::sin(tilt));
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() = *opticalRotationLookingAlong(forward);  // tilted down, never vertical
  world_from_camera.translation() = position;
  return CameraModel(in, distortion, CameraPose::fromWorldFromCamera(world_from_camera));
}

SyntheticLines makeSyntheticLines(const CameraModel& camera, int image_width, int image_height,
                                  const SyntheticLineOptions& options, std::mt19937& rng)
{
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  // Standard normals scaled here: normal_distribution requires a positive sigma, and 0 is a valid noise level.
  std::normal_distribution<double> standard(0.0, 1.0);
  auto image_noise = [&](std::mt19937& g) { return options.image_noise_px * standard(g); };
  auto world_noise = [&](std::mt19937& g) { return options.world_noise_m * standard(g); };
  std::uniform_int_distribution<int> axis(0, 2);
  const Eigen::Isometry3d world_from_camera = camera.pose().worldFromCamera();

  SyntheticLines out;
  out.data.image_width = image_width;
  out.data.image_height = image_height;
  const int image_points = std::max(2, options.image_points_per_line);
  const int world_points = std::max(1, options.world_points_per_line);
  const int max_attempts = 1000 * std::max(1, options.lines);
  for (int attempt = 0; attempt < max_attempts && static_cast<int>(out.segments.size()) < options.lines; ++attempt)
  {
    const Eigen::Vector2d pixel(options.margin_px + unit(rng) * (image_width - 1 - 2 * options.margin_px),
                                options.margin_px + unit(rng) * (image_height - 1 - 2 * options.margin_px));
    const auto ray = camera.backProject(pixel);
    if (!ray)
      continue;
    const double depth = options.depth_min_m + unit(rng) * (options.depth_max_m - options.depth_min_m);
    const Eigen::Vector3d a = world_from_camera * (*ray * (depth / ray->z()));
    const Eigen::Vector3d direction = options.axis_aligned ? Eigen::Vector3d::Unit(axis(rng)) : randomUnitVector(rng);
    const double length = 0.3 + 2.7 * unit(rng);
    const Eigen::Vector3d b = a + length * direction;

    // The whole distorted image of the segment must be in the frame and long enough.
    bool inside = true;
    for (int k = 0; k <= 16 && inside; ++k)
    {
      const auto m = camera.project(a + (b - a) * (k / 16.0));
      inside = m && insideImage(*m, image_width, image_height, options.margin_px);
    }
    if (!inside)
      continue;
    const Eigen::Vector2d ma = *camera.project(a);
    const Eigen::Vector2d mb = *camera.project(b);
    if ((ma - mb).norm() < options.min_image_length_px)
      continue;

    LineCorrespondence line;
    for (int k = 0; k < image_points; ++k)
    {
      const Eigen::Vector2d m = *camera.project(a + (b - a) * (k / double(image_points - 1)));
      line.image.push_back(m + Eigen::Vector2d(image_noise(rng), image_noise(rng)));
    }
    for (int k = 0; k < world_points; ++k)
    {
      const double t = world_points == 1 ? 0.5 : k / double(world_points - 1);
      line.world.push_back(a + (b - a) * t + Eigen::Vector3d(world_noise(rng), world_noise(rng), world_noise(rng)));
    }
    out.segments.push_back({a, b});
    out.data.lines.push_back(std::move(line));
  }
  return out;
}

std::vector<PointCorrespondence> endPointCorrespondences(const CameraModel& camera,
                                                         const std::vector<Segment3d>& segments, double image_noise_px,
                                                         std::mt19937& rng)
{
  std::normal_distribution<double> standard(0.0, 1.0);
  auto noise = [&](std::mt19937& g) { return image_noise_px * standard(g); };
  std::vector<PointCorrespondence> out;
  for (const auto& s : segments)
    for (const Eigen::Vector3d& x : {s.a, s.b})
    {
      const auto m = camera.project(x);
      if (m)
        out.push_back({*m + Eigen::Vector2d(noise(rng), noise(rng)), x});
    }
  return out;
}

SyntheticLines makeDensePolylines(const CameraModel& camera, int image_width, int image_height,
                                  const DensePolylineOptions& options, std::mt19937& rng)
{
  // Exact segments from the generic generator (its lengths cover 0.3-3 m), those of the wanted length kept and cut
  // into image and world points here, each line with its own counts.
  SyntheticLineOptions segment_options;
  segment_options.lines = 8 * options.lines;
  segment_options.min_image_length_px = options.min_image_length_px;
  const SyntheticLines candidates = makeSyntheticLines(camera, image_width, image_height, segment_options, rng);
  std::normal_distribution<double> standard(0.0, 1.0);
  std::uniform_int_distribution<int> image_count(options.image_points_min, options.image_points_max);
  std::uniform_int_distribution<int> world_count(options.world_points_min, options.world_points_max);
  SyntheticLines out;
  out.data.image_width = image_width;
  out.data.image_height = image_height;
  for (const Segment3d& s : candidates.segments)
  {
    const double length = (s.b - s.a).norm();
    if (static_cast<int>(out.segments.size()) >= options.lines || length < options.segment_min_m ||
        length > options.segment_max_m)
      continue;
    LineCorrespondence line;
    const int n = std::max(2, image_count(rng));
    const int m = std::max(1, world_count(rng));
    for (int k = 0; k < n; ++k)
      line.image.push_back(*camera.project(s.pointAt(k / double(n - 1))) +
                           options.image_noise_px * Eigen::Vector2d(standard(rng), standard(rng)));
    for (int k = 0; k < m; ++k)
      line.world.push_back(s.pointAt(m == 1 ? 0.5 : k / double(m - 1)) +
                           options.world_noise_m * Eigen::Vector3d(standard(rng), standard(rng), standard(rng)));
    out.segments.push_back(s);
    out.data.lines.push_back(std::move(line));
  }
  return out;
}

}  // namespace insitu_calibration
