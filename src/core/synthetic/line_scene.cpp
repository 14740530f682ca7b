#include "insitu_calibration/synthetic/line_scene.h"

#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace insitu_calibration
{
namespace
{
struct PreparedQuad
{
  Eigen::Vector3d origin;
  Eigen::Vector3d normal;
  Eigen::Vector3d u_dual;  // a = (p - origin) . u_dual
  Eigen::Vector3d v_dual;
};

std::vector<PreparedQuad> prepare(const LineScene& scene)
{
  std::vector<PreparedQuad> out;
  out.reserve(scene.quads.size());
  for (const auto& q : scene.quads)
  {
    PreparedQuad p;
    p.origin = q.origin;
    p.normal = q.u.cross(q.v);
    const Eigen::Vector3d vn = q.v.cross(p.normal);
    const Eigen::Vector3d nu = p.normal.cross(q.u);
    p.u_dual = vn / q.u.dot(vn);
    p.v_dual = nu / q.v.dot(nu);
    out.push_back(p);
  }
  return out;
}

int intersectPrepared(const std::vector<PreparedQuad>& quads, const Eigen::Vector3d& o, const Eigen::Vector3d& dir,
                      double* distance)
{
  int best = -1;
  double best_t = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < quads.size(); ++i)
  {
    const PreparedQuad& q = quads[i];
    const double denom = q.normal.dot(dir);
    if (std::abs(denom) < 1e-12)
      continue;
    const double t = q.normal.dot(q.origin - o) / denom;
    if (!(t > 1e-9) || t >= best_t)
      continue;
    const Eigen::Vector3d p = o + t * dir - q.origin;
    const double a = p.dot(q.u_dual);
    const double b = p.dot(q.v_dual);
    if (a < 0.0 || a > 1.0 || b < 0.0 || b > 1.0)
      continue;
    best_t = t;
    best = static_cast<int>(i);
  }
  if (distance)
    *distance = best_t;
  return best;
}

double halton(int index, int base)
{
  double f = 1.0, r = 0.0;
  while (index > 0)
  {
    f /= base;
    r += f * (index % base);
    index /= base;
  }
  return r;
}

// The world ray through a distorted pixel; false where the camera model is not invertible.
bool pixelRay(const CameraModel& camera, double x, double y, Eigen::Vector3d* origin, Eigen::Vector3d* direction,
              Eigen::Vector3d* camera_direction)
{
  const auto ray = camera.backProject(Eigen::Vector2d(x, y));
  if (!ray)
    return false;
  *origin = camera.pose().center();
  *direction = camera.pose().rotation.transpose() * *ray;
  if (camera_direction)
    *camera_direction = *ray;
  return true;
}

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

int LineScene::intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double* distance) const
{
  return intersectPrepared(prepare(*this), origin, direction, distance);
}

LineScene makeRoomScene(std::mt19937& rng)
{
  std::uniform_real_distribution<double> jitter(-12.0, 12.0);
  auto g = [&](double base) { return std::clamp(base + jitter(rng), 5.0, 250.0); };
  const double lx = 6.0, ly = 5.0, lz = 2.7;
  LineScene s;
  s.background_grey = 0.0;
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

cv::Mat renderGrey(const LineScene& scene, const CameraModel& camera, int width, int height,
                   const RenderOptions& options, std::mt19937& rng)
{
  const std::vector<PreparedQuad> quads = prepare(scene);
  cv::Mat ids(height, width, CV_32S, cv::Scalar(-1));
  cv::Mat grey(height, width, CV_32F, cv::Scalar(scene.background_grey));
  auto greyOf = [&](int id) { return id < 0 ? scene.background_grey : scene.quads[id].grey; };
  Eigen::Vector3d o, dir;
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      if (!pixelRay(camera, x, y, &o, &dir, nullptr))
        continue;
      const int id = intersectPrepared(quads, o, dir, nullptr);
      ids.at<int>(y, x) = id;
      grey.at<float>(y, x) = static_cast<float>(greyOf(id));
    }
  }
  if (options.supersamples > 1)
  {
    std::vector<Eigen::Vector2d> offsets;
    for (int i = 1; i <= options.supersamples; ++i)
      offsets.emplace_back(halton(i, 2) - 0.5, halton(i, 3) - 0.5);
    for (int y = 0; y < height; ++y)
    {
      for (int x = 0; x < width; ++x)
      {
        const int id = ids.at<int>(y, x);
        bool boundary = false;
        for (int dy = -1; dy <= 1 && !boundary; ++dy)
          for (int dx = -1; dx <= 1 && !boundary; ++dx)
          {
            const int xx = x + dx, yy = y + dy;
            if (xx >= 0 && yy >= 0 && xx < width && yy < height && ids.at<int>(yy, xx) != id)
              boundary = true;
          }
        if (!boundary)
          continue;
        double sum = 0.0;
        for (const auto& off : offsets)
        {
          int hit = -1;
          if (pixelRay(camera, x + off.x(), y + off.y(), &o, &dir, nullptr))
            hit = intersectPrepared(quads, o, dir, nullptr);
          sum += greyOf(hit);
        }
        grey.at<float>(y, x) = static_cast<float>(sum / offsets.size());
      }
    }
  }
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
  const std::vector<PreparedQuad> quads = prepare(scene);
  cv::Mat depth(height, width, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  Eigen::Vector3d o, dir, ray_c;
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      if (!pixelRay(camera, x, y, &o, &dir, &ray_c))
        continue;
      double t = 0.0;
      if (intersectPrepared(quads, o, dir, &t) >= 0)
        depth.at<float>(y, x) = static_cast<float>(t * ray_c.z());
    }
  }
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
