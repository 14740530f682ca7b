#include "insitu_calibration/simulation/renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace insitu_calibration
{
namespace simulation
{
namespace
{
constexpr int kTile = 16;
constexpr int kRegionsPerSurface = 1024;

// A surface in the optical frame: plane n . X = d, texture coordinates u = au . X + bu, v = av . X + bv.
struct CameraSurface
{
  Eigen::Vector3d n;
  double d;
  Eigen::Vector3d au;
  double bu;
  Eigen::Vector3d av;
  double bv;
};

// Sutherland-Hodgman against the plane z = near: keeps z >= near.
void clipNear(const std::vector<Eigen::Vector3d>& in, double near, std::vector<Eigen::Vector3d>& out)
{
  out.clear();
  const size_t n = in.size();
  for (size_t i = 0; i < n; ++i)
  {
    const Eigen::Vector3d& a = in[i];
    const Eigen::Vector3d& b = in[(i + 1) % n];
    const bool a_in = a.z() >= near;
    const bool b_in = b.z() >= near;
    if (a_in)
      out.push_back(a);
    if (a_in != b_in)
    {
      const double t = (near - a.z()) / (b.z() - a.z());
      Eigen::Vector3d p = a + t * (b - a);
      p.z() = near;
      out.push_back(p);
    }
  }
}
}  // namespace

struct Renderer::Prepared
{
  Eigen::Matrix3d camera_from_world;
  Eigen::Vector3d translation;  // X_c = camera_from_world X + translation
  std::vector<CameraSurface> surfaces;
};

ViewCamera ViewCamera::fromModel(const CameraModel& model, int width, int height)
{
  ViewCamera v;
  v.width = width;
  v.height = height;
  v.intrinsics = model.intrinsics();
  v.distortion = model.distortion();
  v.world_from_camera = model.pose().worldFromCamera();
  return v;
}

std::optional<Eigen::Vector3d> ViewCamera::ray(double x, double y) const
{
  if (distortion.lambda != 0.0)
  {
    const double dx = x - distortion.center.x();
    const double dy = y - distortion.center.y();
    const double den = 1.0 + distortion.lambda * (dx * dx + dy * dy);
    if (!(den > 1e-9))
      return std::nullopt;
    x = distortion.center.x() + dx / den;
    y = distortion.center.y() + dy / den;
  }
  const double yn = (y - intrinsics.cy) / intrinsics.fy;
  const double xn = (x - intrinsics.cx - intrinsics.skew * yn) / intrinsics.fx;
  return Eigen::Vector3d(xn, yn, 1.0);
}

Renderer::Renderer(const World& world) : world_(world)
{
  for (const Surface& s : world.surfaces)
  {
    const double lambert = std::abs(s.normal.dot(world.lighting.direction));
    shade_.push_back(static_cast<float>(world.lighting.ambient + world.lighting.diffuse * lambert));
    Eigen::Vector4d b(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                      -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity());
    for (const auto& ring : s.rings_uv)
      for (const auto& p : ring)
      {
        b[0] = std::min(b[0], p.x());
        b[1] = std::min(b[1], p.y());
        b[2] = std::max(b[2], p.x());
        b[3] = std::max(b[3], p.y());
      }
    uv_bounds_.push_back(b);
  }
}

void Renderer::rasterize(const ViewCamera& cam, const Prepared& p, const RenderOptions& options, cv::Mat& inverse_depth,
                         cv::Mat& surface) const
{
  const int w = cam.width;
  const int h = cam.height;
  const Intrinsics& k = cam.intrinsics;
  struct Edge
  {
    double x0, y0, y1, dxdy;
  };
  std::vector<Edge> edges;
  std::vector<Eigen::Vector3d> ring_c;
  std::vector<Eigen::Vector3d> clipped;
  std::vector<double> xs;
  for (size_t i = 0; i < world_.surfaces.size(); ++i)
  {
    const CameraSurface& cs = p.surfaces[i];
    if (std::abs(cs.d) < 1e-9)
      continue;  // the plane passes through the optical centre: the polygon is seen edge-on
    edges.clear();
    double ymin = std::numeric_limits<double>::infinity();
    double ymax = -ymin;
    double xmin = ymin;
    double xmax = -ymin;
    for (const auto& ring : world_.surfaces[i].rings)
    {
      ring_c.clear();
      bool any_in_front = false;
      for (const auto& x : ring)
      {
        ring_c.push_back(p.camera_from_world * x + p.translation);
        any_in_front |= ring_c.back().z() >= options.near_m;
      }
      if (!any_in_front)
        continue;
      clipNear(ring_c, options.near_m, clipped);
      const size_t n = clipped.size();
      if (n < 3)
        continue;
      double px_prev = 0.0, py_prev = 0.0;
      double px_first = 0.0, py_first = 0.0;
      for (size_t j = 0; j <= n; ++j)
      {
        double px, py;
        if (j < n)
        {
          const Eigen::Vector3d& x = clipped[j];
          const double iz = 1.0 / x.z();
          px = k.fx * x.x() * iz + k.skew * x.y() * iz + k.cx;
          py = k.fy * x.y() * iz + k.cy;
          ymin = std::min(ymin, py);
          ymax = std::max(ymax, py);
          xmin = std::min(xmin, px);
          xmax = std::max(xmax, px);
          if (j == 0)
          {
            px_first = px;
            py_first = py;
          }
        }
        else
        {
          px = px_first;
          py = py_first;
        }
        if (j > 0 && py != py_prev)
          edges.push_back({px_prev, py_prev, py, (px - px_prev) / (py - py_prev)});
        px_prev = px;
        py_prev = py;
      }
    }
    if (edges.empty() || xmax < 0.0 || xmin > w - 1.0)
      continue;
    const int row0 = std::max(0, static_cast<int>(std::ceil(ymin)));
    const int row1 = std::min(h - 1, static_cast<int>(std::floor(ymax)));
    // 1/z = a x + b y + c from n . (z ray(x, y)) = d.
    const Eigen::Vector3d& n = cs.n;
    const double a = n.x() / (k.fx * cs.d);
    const double b = (n.y() / k.fy - n.x() * k.skew / (k.fx * k.fy)) / cs.d;
    const double c = (n.z() - n.y() * k.cy / k.fy + n.x() * (k.skew * k.cy / (k.fx * k.fy) - k.cx / k.fx)) / cs.d;
    const int id = static_cast<int>(i);
    for (int y = row0; y <= row1; ++y)
    {
      xs.clear();
      for (const Edge& e : edges)
        if ((e.y0 <= y && y < e.y1) || (e.y1 <= y && y < e.y0))
          xs.push_back(e.x0 + (y - e.y0) * e.dxdy);
      if (xs.size() < 2)
        continue;
      std::sort(xs.begin(), xs.end());
      float* iz_row = inverse_depth.ptr<float>(y);
      int* id_row = surface.ptr<int>(y);
      const double by_c = b * y + c;
      for (size_t s = 0; s + 1 < xs.size(); s += 2)
      {
        const int x0 = std::max(0, static_cast<int>(std::ceil(xs[s])));
        const int x1 = std::min(w - 1, static_cast<int>(std::ceil(xs[s + 1])) - 1);
        for (int x = x0; x <= x1; ++x)
        {
          const float iz = static_cast<float>(a * x + by_c);
          if (iz > iz_row[x])
          {
            iz_row[x] = iz;
            id_row[x] = id;
          }
        }
      }
    }
  }
}

void Renderer::rayCast(const ViewCamera& cam, const Prepared& p, const RenderOptions& options, cv::Mat& depth,
                       cv::Mat& surface) const
{
  const int w = cam.width;
  const int h = cam.height;
  const int tiles_x = (w + kTile - 1) / kTile;
  const int tiles_y = (h + kTile - 1) / kTile;
  std::vector<std::vector<int>> tiles(static_cast<size_t>(tiles_x) * tiles_y);
  const Intrinsics& k = cam.intrinsics;

  // Image bounds of each surface: the distorted image of its near-clipped outline, sampled finely enough (a region's
  // image is bounded by the image of its boundary).
  std::vector<Eigen::Vector3d> ring_c;
  std::vector<Eigen::Vector3d> clipped;
  for (size_t i = 0; i < world_.surfaces.size(); ++i)
  {
    if (std::abs(p.surfaces[i].d) < 1e-9)
      continue;
    double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
    bool full = false;
    for (const auto& ring : world_.surfaces[i].rings)
    {
      ring_c.clear();
      for (const auto& x : ring)
        ring_c.push_back(p.camera_from_world * x + p.translation);
      clipNear(ring_c, options.near_m, clipped);
      const size_t n = clipped.size();
      for (size_t j = 0; j < n && !full; ++j)
      {
        const Eigen::Vector3d& a = clipped[j];
        const Eigen::Vector3d& b = clipped[(j + 1) % n];
        const Eigen::Vector2d pa(k.fx * a.x() / a.z() + k.skew * a.y() / a.z() + k.cx, k.fy * a.y() / a.z() + k.cy);
        const Eigen::Vector2d pb(k.fx * b.x() / b.z() + k.skew * b.y() / b.z() + k.cx, k.fy * b.y() / b.z() + k.cy);
        const int samples = static_cast<int>(std::clamp((pa - pb).norm() / 2.0, 8.0, 4096.0));
        for (int s = 0; s <= samples; ++s)
        {
          const Eigen::Vector3d x = a + (b - a) * (static_cast<double>(s) / samples);
          const Eigen::Vector2d u(k.fx * x.x() / x.z() + k.skew * x.y() / x.z() + k.cx, k.fy * x.y() / x.z() + k.cy);
          const auto d = cam.distortion.distort(u);
          if (!d)
          {
            full = true;
            break;
          }
          x0 = std::min(x0, d->x());
          x1 = std::max(x1, d->x());
          y0 = std::min(y0, d->y());
          y1 = std::max(y1, d->y());
        }
      }
    }
    if (full)
    {
      x0 = 0;
      y0 = 0;
      x1 = w - 1;
      y1 = h - 1;
    }
    if (!(x1 >= x0))
      continue;
    const int tx0 = std::max(0, static_cast<int>(std::floor(x0 - 2.0)) / kTile);
    const int ty0 = std::max(0, static_cast<int>(std::floor(y0 - 2.0)) / kTile);
    const int tx1 = std::min(tiles_x - 1, static_cast<int>(std::min(x1 + 2.0, w + 1.0)) / kTile);
    const int ty1 = std::min(tiles_y - 1, static_cast<int>(std::min(y1 + 2.0, h + 1.0)) / kTile);
    if (x1 + 2.0 < 0 || y1 + 2.0 < 0 || x0 - 2.0 > w - 1 || y0 - 2.0 > h - 1)
      continue;
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx)
        tiles[static_cast<size_t>(ty) * tiles_x + tx].push_back(static_cast<int>(i));
  }

  for (int y = 0; y < h; ++y)
  {
    float* depth_row = depth.ptr<float>(y);
    int* id_row = surface.ptr<int>(y);
    for (int x = 0; x < w; ++x)
    {
      const auto r = cam.ray(x, y);
      if (!r)
        continue;
      const std::vector<int>& candidates = tiles[static_cast<size_t>(y / kTile) * tiles_x + x / kTile];
      double best = std::numeric_limits<double>::infinity();
      int best_id = -1;
      for (const int i : candidates)
      {
        const CameraSurface& cs = p.surfaces[i];
        const double den = cs.n.dot(*r);
        if (den == 0.0)
          continue;
        const double z = cs.d / den;
        if (!(z >= options.near_m && z < best))
          continue;
        const Eigen::Vector3d xc = z * *r;
        const Eigen::Vector2d uv(cs.au.dot(xc) + cs.bu, cs.av.dot(xc) + cs.bv);
        const Eigen::Vector4d& bb = uv_bounds_[i];
        if (uv.x() < bb[0] || uv.y() < bb[1] || uv.x() > bb[2] || uv.y() > bb[3])
          continue;
        if (!world_.surfaces[i].contains(uv))
          continue;
        best = z;
        best_id = i;
      }
      if (best_id >= 0)
      {
        depth_row[x] = static_cast<float>(best);
        id_row[x] = best_id;
      }
    }
  }
}

RenderedView Renderer::render(const ViewCamera& cam, const RenderOptions& options) const
{
  const int w = cam.width;
  const int h = cam.height;
  Prepared p;
  p.camera_from_world = cam.world_from_camera.linear().transpose();
  p.translation = -p.camera_from_world * cam.world_from_camera.translation();
  const Eigen::Vector3d center = cam.world_from_camera.translation();
  for (const Surface& s : world_.surfaces)
  {
    CameraSurface cs;
    cs.n = p.camera_from_world * s.normal;
    cs.d = s.offset - s.normal.dot(center);
    cs.au = p.camera_from_world * s.axis_u;
    cs.bu = s.axis_u.dot(center - s.origin);
    cs.av = p.camera_from_world * s.axis_v;
    cs.bv = s.axis_v.dot(center - s.origin);
    p.surfaces.push_back(cs);
  }

  RenderedView view;
  view.surface = cv::Mat(h, w, CV_32SC1, cv::Scalar(-1));
  if (cam.distortion.lambda == 0.0 && !options.ray_cast)
  {
    cv::Mat inverse_depth(h, w, CV_32FC1, cv::Scalar(0.0f));
    rasterize(cam, p, options, inverse_depth, view.surface);
    view.depth = cv::Mat(h, w, CV_32FC1, cv::Scalar(0.0f));
    for (int y = 0; y < h; ++y)
    {
      const float* iz = inverse_depth.ptr<float>(y);
      float* z = view.depth.ptr<float>(y);
      for (int x = 0; x < w; ++x)
        z[x] = iz[x] > 0.0f ? 1.0f / iz[x] : 0.0f;
    }
  }
  else
  {
    view.depth = cv::Mat(h, w, CV_32FC1, cv::Scalar(0.0f));
    rayCast(cam, p, options, view.depth, view.surface);
  }

  view.region = cv::Mat(h, w, CV_32SC1, cv::Scalar(-1));
  if (!options.color)
    return view;
  view.rgb = cv::Mat(h, w, CV_8UC3, cv::Scalar(0, 0, 0));

  auto shadeAt = [&](int id, const Eigen::Vector3d& xc, int* region) -> Color {
    const CameraSurface& cs = p.surfaces[id];
    const Color c = world_.surfaces[id].texture.sample(cs.au.dot(xc) + cs.bu, cs.av.dot(xc) + cs.bv, region);
    return c * shade_[id];
  };
  auto store = [](uint8_t* px, const Color& c) {
    for (int ch = 0; ch < 3; ++ch)
      px[ch] = static_cast<uint8_t>(std::clamp(std::lround(c[ch]), 0L, 255L));
  };

  // Shading at the pixel centres.
  for (int y = 0; y < h; ++y)
  {
    const int* id_row = view.surface.ptr<int>(y);
    const float* z_row = view.depth.ptr<float>(y);
    int* region_row = view.region.ptr<int>(y);
    uint8_t* rgb_row = view.rgb.ptr<uint8_t>(y);
    for (int x = 0; x < w; ++x)
    {
      const int id = id_row[x];
      if (id < 0)
        continue;
      const auto r = cam.ray(x, y);
      int region = 0;
      const Color c = shadeAt(id, static_cast<double>(z_row[x]) * *r, &region);
      region_row[x] = id * kRegionsPerSurface + region;
      store(rgb_row + 3 * x, c);
    }
  }

  // Anti-aliasing of the pixels where the surface or the texture region changes.
  const int n = std::max(1, options.supersampling);
  if (n == 1)
    return view;
  cv::Mat edge(h, w, CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < h; ++y)
  {
    const int* r0 = view.region.ptr<int>(y);
    const int* r1 = y + 1 < h ? view.region.ptr<int>(y + 1) : nullptr;
    uint8_t* e0 = edge.ptr<uint8_t>(y);
    uint8_t* e1 = y + 1 < h ? edge.ptr<uint8_t>(y + 1) : nullptr;
    for (int x = 0; x < w; ++x)
    {
      if (x + 1 < w && r0[x] != r0[x + 1])
        e0[x] = e0[x + 1] = 1;
      if (r1 && r0[x] != r1[x])
        e0[x] = e1[x] = 1;
    }
  }
  int candidates[9];
  for (int y = 0; y < h; ++y)
  {
    const uint8_t* e = edge.ptr<uint8_t>(y);
    for (int x = 0; x < w; ++x)
    {
      if (!e[x])
        continue;
      int count = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
        {
          const int yy = y + dy, xx = x + dx;
          if (yy < 0 || yy >= h || xx < 0 || xx >= w)
            continue;
          const int id = view.surface.at<int>(yy, xx);
          if (id >= 0 && std::find(candidates, candidates + count, id) == candidates + count)
            candidates[count++] = id;
        }
      Color sum = Color::Zero();
      for (int sy = 0; sy < n; ++sy)
        for (int sx = 0; sx < n; ++sx)
        {
          const auto r = cam.ray(x + (sx + 0.5) / n - 0.5, y + (sy + 0.5) / n - 0.5);
          if (!r)
            continue;
          double best = std::numeric_limits<double>::infinity();
          int best_id = -1;
          for (int c = 0; c < count; ++c)
          {
            const int i = candidates[c];
            const CameraSurface& cs = p.surfaces[i];
            const double den = cs.n.dot(*r);
            if (den == 0.0)
              continue;
            const double z = cs.d / den;
            if (!(z >= options.near_m && z < best))
              continue;
            const Eigen::Vector3d xc = z * *r;
            if (!world_.surfaces[i].contains(Eigen::Vector2d(cs.au.dot(xc) + cs.bu, cs.av.dot(xc) + cs.bv)))
              continue;
            best = z;
            best_id = i;
          }
          if (best_id >= 0)
          {
            int region = 0;
            sum += shadeAt(best_id, best * *r, &region);
          }
        }
      store(view.rgb.ptr<uint8_t>(y) + 3 * x, sum / static_cast<float>(n * n));
      ++view.antialiased_pixels;
    }
  }
  return view;
}

}  // namespace simulation
}  // namespace insitu_calibration
