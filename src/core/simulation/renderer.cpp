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
  Eigen::Vector3d light;        // towards the light, in the camera frame
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

namespace
{
// A polygon's outline as scanline edges (pixel coordinates of the pin-hole image), and its bounds.
struct ScanEdge
{
  double x0, y0, y1, dxdy;
};
struct Outline
{
  std::vector<ScanEdge> edges;
  double ymin = std::numeric_limits<double>::infinity();
  double ymax = -std::numeric_limits<double>::infinity();
  double xmin = std::numeric_limits<double>::infinity();
  double xmax = -std::numeric_limits<double>::infinity();
};

Eigen::Vector2d pinholePixel(const Intrinsics& k, const Eigen::Vector3d& x)
{
  return {k.fx * x.x() / x.z() + k.skew * x.y() / x.z() + k.cx, k.fy * x.y() / x.z() + k.cy};
}

// Adds one near-clipped ring (optical frame) to the outline.
void addRingEdges(const std::vector<Eigen::Vector3d>& clipped, const Intrinsics& k, Outline* o)
{
  const size_t n = clipped.size();
  double px_prev = 0.0, py_prev = 0.0;
  double px_first = 0.0, py_first = 0.0;
  for (size_t j = 0; j <= n; ++j)
  {
    double px = px_first, py = py_first;
    if (j < n)
    {
      const Eigen::Vector3d& x = clipped[j];
      const double iz = 1.0 / x.z();
      px = k.fx * x.x() * iz + k.skew * x.y() * iz + k.cx;
      py = k.fy * x.y() * iz + k.cy;
      o->ymin = std::min(o->ymin, py);
      o->ymax = std::max(o->ymax, py);
      o->xmin = std::min(o->xmin, px);
      o->xmax = std::max(o->xmax, px);
      if (j == 0)
      {
        px_first = px;
        py_first = py;
      }
    }
    if (j > 0 && py != py_prev)
      o->edges.push_back({px_prev, py_prev, py, (px - px_prev) / (py - py_prev)});
    px_prev = px;
    py_prev = py;
  }
}

// Whether an image point's distortion leaves the division model's domain (the image of the whole plane).
struct ImageBox
{
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  bool full = false;  // some point of the outline has no distorted image: the whole image may be covered
  void add(const Eigen::Vector2d& d)
  {
    x0 = std::min(x0, d.x());
    x1 = std::max(x1, d.x());
    y0 = std::min(y0, d.y());
    y1 = std::max(y1, d.y());
  }
};

// The distorted image of a near-clipped ring's edges, sampled finely enough (a region's image is bounded by the
// image of its boundary).
void addRingImage(const std::vector<Eigen::Vector3d>& clipped, const ViewCamera& cam, ImageBox* box)
{
  const Intrinsics& k = cam.intrinsics;
  const size_t n = clipped.size();
  for (size_t j = 0; j < n && !box->full; ++j)
  {
    const Eigen::Vector3d& a = clipped[j];
    const Eigen::Vector3d& b = clipped[(j + 1) % n];
    const int samples =
        static_cast<int>(std::clamp((pinholePixel(k, a) - pinholePixel(k, b)).norm() / 2.0, 8.0, 4096.0));
    for (int s = 0; s <= samples; ++s)
    {
      const auto d = cam.distortion.distort(pinholePixel(k, a + (b - a) * (static_cast<double>(s) / samples)));
      if (!d)
      {
        box->full = true;
        break;
      }
      box->add(*d);
    }
  }
}

// Fills one polygon's rows row0..row1 where it is nearer than what is there (inverse depth interpolated exactly).
void fillPolygon(const ViewCamera& cam, const CameraSurface& cs, int id, const std::vector<ScanEdge>& edges, int row0,
                 int row1, cv::Mat& inverse_depth, cv::Mat& surface)
{
  const Intrinsics& k = cam.intrinsics;
  // 1/z = a x + b y + c from n . (z ray(x, y)) = d.
  const Eigen::Vector3d& n = cs.n;
  const double a = n.x() / (k.fx * cs.d);
  const double b = (n.y() / k.fy - n.x() * k.skew / (k.fx * k.fy)) / cs.d;
  const double c = (n.z() - n.y() * k.cy / k.fy + n.x() * (k.skew * k.cy / (k.fx * k.fy) - k.cx / k.fx)) / cs.d;
  std::vector<double> xs;
  for (int y = row0; y <= row1; ++y)
  {
    xs.clear();
    for (const ScanEdge& e : edges)
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
      const int x1 = std::min(cam.width - 1, static_cast<int>(std::ceil(xs[s + 1])) - 1);
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

void storeColor(uint8_t* px, const Color& c)
{
  for (int ch = 0; ch < 3; ++ch)
    px[ch] = static_cast<uint8_t>(std::clamp(std::lround(c[ch]), 0L, 255L));
}
}  // namespace

void Renderer::toCamera(const Prepared& p, const std::vector<Eigen::Vector3d>& ring,
                        std::vector<Eigen::Vector3d>* out) const
{
  out->clear();
  for (const auto& x : ring)
    out->push_back(p.camera_from_world * x + p.translation);
}

int Renderer::nearestSurface(const Prepared& p, const int* candidates, size_t count, const Eigen::Vector3d& ray,
                             double near_m, double* depth) const
{
  double best = std::numeric_limits<double>::infinity();
  int best_id = -1;
  for (size_t c = 0; c < count; ++c)
  {
    const int i = candidates[c];
    const CameraSurface& cs = p.surfaces[i];
    const double den = cs.n.dot(ray);
    if (den == 0.0)
      continue;
    const double z = cs.d / den;
    if (!(z >= near_m && z < best))
      continue;
    const Eigen::Vector3d xc = z * ray;
    const Eigen::Vector2d uv(cs.au.dot(xc) + cs.bu, cs.av.dot(xc) + cs.bv);
    // The bounds are a quick rejection: contains() refuses every point outside them too.
    const Eigen::Vector4d& bb = uv_bounds_[i];
    if (uv.x() < bb[0] || uv.y() < bb[1] || uv.x() > bb[2] || uv.y() > bb[3])
      continue;
    if (!world_.surfaces[i].contains(uv))
      continue;
    best = z;
    best_id = i;
  }
  *depth = best;
  return best_id;
}

void Renderer::rasterize(const ViewCamera& cam, const Prepared& p, const RenderOptions& options, cv::Mat& inverse_depth,
                         cv::Mat& surface) const
{
  std::vector<Eigen::Vector3d> ring_c;
  std::vector<Eigen::Vector3d> clipped;
  for (size_t i = 0; i < world_.surfaces.size(); ++i)
  {
    const CameraSurface& cs = p.surfaces[i];
    if (std::abs(cs.d) < 1e-9)
      continue;  // the plane passes through the optical centre: the polygon is seen edge-on
    Outline outline;
    for (const auto& ring : world_.surfaces[i].rings)
    {
      toCamera(p, ring, &ring_c);
      if (std::none_of(ring_c.begin(), ring_c.end(), [&](const Eigen::Vector3d& x) { return x.z() >= options.near_m; }))
        continue;
      clipNear(ring_c, options.near_m, clipped);
      if (clipped.size() >= 3)
        addRingEdges(clipped, cam.intrinsics, &outline);
    }
    if (outline.edges.empty() || outline.xmax < 0.0 || outline.xmin > cam.width - 1.0)
      continue;
    const int row0 = std::max(0, static_cast<int>(std::ceil(outline.ymin)));
    const int row1 = std::min(cam.height - 1, static_cast<int>(std::floor(outline.ymax)));
    fillPolygon(cam, cs, static_cast<int>(i), outline.edges, row0, row1, inverse_depth, surface);
  }
}

std::vector<std::vector<int>> Renderer::surfacesPerTile(const ViewCamera& cam, const Prepared& p,
                                                        const RenderOptions& options) const
{
  const int w = cam.width;
  const int h = cam.height;
  const int tiles_x = (w + kTile - 1) / kTile;
  const int tiles_y = (h + kTile - 1) / kTile;
  std::vector<std::vector<int>> tiles(static_cast<size_t>(tiles_x) * tiles_y);
  std::vector<Eigen::Vector3d> ring_c;
  std::vector<Eigen::Vector3d> clipped;
  for (size_t i = 0; i < world_.surfaces.size(); ++i)
  {
    if (std::abs(p.surfaces[i].d) < 1e-9)
      continue;
    ImageBox box;
    for (const auto& ring : world_.surfaces[i].rings)
    {
      toCamera(p, ring, &ring_c);
      clipNear(ring_c, options.near_m, clipped);
      addRingImage(clipped, cam, &box);
    }
    if (box.full)
      box = {0.0, 0.0, w - 1.0, h - 1.0, true};
    if (!(box.x1 >= box.x0))
      continue;
    const int tx0 = std::max(0, static_cast<int>(std::floor(box.x0 - 2.0)) / kTile);
    const int ty0 = std::max(0, static_cast<int>(std::floor(box.y0 - 2.0)) / kTile);
    const int tx1 = std::min(tiles_x - 1, static_cast<int>(std::min(box.x1 + 2.0, w + 1.0)) / kTile);
    const int ty1 = std::min(tiles_y - 1, static_cast<int>(std::min(box.y1 + 2.0, h + 1.0)) / kTile);
    if (box.x1 + 2.0 < 0 || box.y1 + 2.0 < 0 || box.x0 - 2.0 > w - 1 || box.y0 - 2.0 > h - 1)
      continue;
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx)
        tiles[static_cast<size_t>(ty) * tiles_x + tx].push_back(static_cast<int>(i));
  }
  return tiles;
}

void Renderer::rayCast(const ViewCamera& cam, const Prepared& p, const RenderOptions& options, cv::Mat& depth,
                       cv::Mat& surface) const
{
  const int tiles_x = (cam.width + kTile - 1) / kTile;
  const std::vector<std::vector<int>> tiles = surfacesPerTile(cam, p, options);
  for (int y = 0; y < cam.height; ++y)
  {
    float* depth_row = depth.ptr<float>(y);
    int* id_row = surface.ptr<int>(y);
    for (int x = 0; x < cam.width; ++x)
    {
      const auto r = cam.ray(x, y);
      if (!r)
        continue;
      const std::vector<int>& candidates = tiles[static_cast<size_t>(y / kTile) * tiles_x + x / kTile];
      double best = 0.0;
      const int best_id = nearestSurface(p, candidates.data(), candidates.size(), *r, options.near_m, &best);
      if (best_id >= 0)
      {
        depth_row[x] = static_cast<float>(best);
        id_row[x] = best_id;
      }
    }
  }
}

Renderer::Prepared Renderer::prepare(const ViewCamera& cam) const
{
  Prepared p;
  p.camera_from_world = cam.world_from_camera.linear().transpose();
  p.translation = -p.camera_from_world * cam.world_from_camera.translation();
  const Eigen::Vector3d center = cam.world_from_camera.translation();
  p.light = p.camera_from_world * world_.lighting.direction;
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
  return p;
}

// Visibility: the rasterizer for pin-hole views (fast), the ray caster through the division model otherwise.
void Renderer::renderVisibility(const ViewCamera& cam, const Prepared& p, const RenderOptions& options,
                                RenderedView* view) const
{
  const int w = cam.width;
  const int h = cam.height;
  view->surface = cv::Mat(h, w, CV_32SC1, cv::Scalar(-1));
  view->depth = cv::Mat(h, w, CV_32FC1, cv::Scalar(0.0f));
  if (cam.distortion.lambda != 0.0 || options.ray_cast)
  {
    rayCast(cam, p, options, view->depth, view->surface);
    return;
  }
  cv::Mat inverse_depth(h, w, CV_32FC1, cv::Scalar(0.0f));
  rasterize(cam, p, options, inverse_depth, view->surface);
  for (int y = 0; y < h; ++y)
  {
    const float* iz = inverse_depth.ptr<float>(y);
    float* z = view->depth.ptr<float>(y);
    for (int x = 0; x < w; ++x)
      z[x] = iz[x] > 0.0f ? 1.0f / iz[x] : 0.0f;
  }
}

Color Renderer::shadeAt(const Prepared& p, int id, const Eigen::Vector3d& xc, int* region) const
{
  const CameraSurface& cs = p.surfaces[id];
  const Texture& texture = world_.surfaces[id].texture;
  const Color c = texture.sample(cs.au.dot(xc) + cs.bu, cs.av.dot(xc) + cs.bv, region);
  if (texture.shine == 0.0)
    return c * shade_[id];
  // A glossy highlight (Blinn-Phong, exponent 40) of the light mirrored onto the viewer's side of the surface, as the
  // constant Lambert factor lights both sides.
  const Eigen::Vector3d view = -xc.normalized();
  const Eigen::Vector3d n = cs.n.dot(view) >= 0.0 ? cs.n : Eigen::Vector3d(-cs.n);
  const Eigen::Vector3d light = n.dot(p.light) >= 0.0 ? p.light : Eigen::Vector3d(p.light - 2.0 * n.dot(p.light) * n);
  const double highlight = texture.shine * 255.0 * std::pow(std::max(0.0, n.dot((light + view).normalized())), 40.0);
  return (c * shade_[id] + Color::Constant(static_cast<float>(highlight))).cwiseMin(255.0f);
}

// Shading and texture regions at the pixel centres.
void Renderer::shadePixels(const ViewCamera& cam, const Prepared& p, RenderedView* view) const
{
  for (int y = 0; y < cam.height; ++y)
  {
    const int* id_row = view->surface.ptr<int>(y);
    const float* z_row = view->depth.ptr<float>(y);
    int* region_row = view->region.ptr<int>(y);
    uint8_t* rgb_row = view->rgb.ptr<uint8_t>(y);
    for (int x = 0; x < cam.width; ++x)
    {
      const int id = id_row[x];
      if (id < 0)
        continue;
      const auto r = cam.ray(x, y);
      int region = 0;
      const Color c = shadeAt(p, id, static_cast<double>(z_row[x]) * *r, &region);
      region_row[x] = id * kRegionsPerSurface + region;
      storeColor(rgb_row + 3 * x, c);
    }
  }
}

namespace
{
// The pixels on either side of a change of surface or texture region.
cv::Mat regionEdges(const cv::Mat& region)
{
  const int h = region.rows, w = region.cols;
  cv::Mat edge(h, w, CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < h; ++y)
  {
    const int* r0 = region.ptr<int>(y);
    const int* r1 = y + 1 < h ? region.ptr<int>(y + 1) : nullptr;
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
  return edge;
}

// The distinct surfaces of a pixel's 3 x 3 neighbourhood; returns their number.
int neighbourSurfaces(const cv::Mat& surface, int x, int y, int* candidates)
{
  int count = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
    {
      const int yy = y + dy, xx = x + dx;
      if (yy < 0 || yy >= surface.rows || xx < 0 || xx >= surface.cols)
        continue;
      const int id = surface.at<int>(yy, xx);
      if (id >= 0 && std::find(candidates, candidates + count, id) == candidates + count)
        candidates[count++] = id;
    }
  return count;
}
}  // namespace

// Anti-aliasing: each pixel where the surface or the texture region changes is the mean of n x n samples, each
// shaded from the nearest of the neighbourhood's surfaces.
void Renderer::antialias(const ViewCamera& cam, const Prepared& p, const RenderOptions& options, int n,
                         RenderedView* view) const
{
  const cv::Mat edge = regionEdges(view->region);
  int candidates[9];
  for (int y = 0; y < cam.height; ++y)
  {
    const uint8_t* e = edge.ptr<uint8_t>(y);
    for (int x = 0; x < cam.width; ++x)
    {
      if (!e[x])
        continue;
      const int count = neighbourSurfaces(view->surface, x, y, candidates);
      Color sum = Color::Zero();
      for (int sy = 0; sy < n; ++sy)
        for (int sx = 0; sx < n; ++sx)
        {
          const auto r = cam.ray(x + (sx + 0.5) / n - 0.5, y + (sy + 0.5) / n - 0.5);
          if (!r)
            continue;
          double best = 0.0;
          const int best_id = nearestSurface(p, candidates, static_cast<size_t>(count), *r, options.near_m, &best);
          int region = 0;
          if (best_id >= 0)
            sum += shadeAt(p, best_id, best * *r, &region);
        }
      storeColor(view->rgb.ptr<uint8_t>(y) + 3 * x, sum / static_cast<float>(n * n));
      ++view->antialiased_pixels;
    }
  }
}

RenderedView Renderer::render(const ViewCamera& cam, const RenderOptions& options) const
{
  const Prepared p = prepare(cam);
  RenderedView view;
  renderVisibility(cam, p, options, &view);
  view.region = cv::Mat(cam.height, cam.width, CV_32SC1, cv::Scalar(-1));
  if (!options.color)
    return view;
  view.rgb = cv::Mat(cam.height, cam.width, CV_8UC3, cv::Scalar(0, 0, 0));
  shadePixels(cam, p, &view);
  const int n = std::max(1, options.supersampling);
  if (n > 1)
    antialias(cam, p, options, n, &view);
  return view;
}

}  // namespace simulation
}  // namespace insitu_calibration
