#include "generator_scene.h"

#include <cmath>
#include <cstdio>

namespace insitu_calibration
{
namespace simulation
{
namespace generator
{
Color Rng::color(const std::vector<Color>& palette, double jitter)
{
  Color c = palette[static_cast<size_t>(integer(0, static_cast<int>(palette.size()) - 1))];
  for (int k = 0; k < 3; ++k)
    c[k] = static_cast<float>(std::clamp(std::round(c[k] + uniform(-jitter, jitter)), 0.0, 255.0));
  return c;
}

std::string num(double x)
{
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.3f", std::abs(x) < 5e-4 ? 0.0 : x);
  std::string s = buffer;
  while (s.back() == '0')
    s.pop_back();
  if (s.back() == '.')
    s.pop_back();
  return s;
}

std::string vec(std::initializer_list<double> v)
{
  std::string s = "[";
  for (const double x : v)
    s += (s.size() > 1 ? ", " : "") + num(x);
  return s + "]";
}
std::string vec2(const Eigen::Vector2d& v)
{
  return vec({v.x(), v.y()});
}
std::string vec3(const Eigen::Vector3d& v)
{
  return vec({v.x(), v.y(), v.z()});
}

namespace
{
std::string colorYaml(const Color& c)
{
  return vec({std::round(c[0]), std::round(c[1]), std::round(c[2])});
}
}  // namespace

namespace
{
const char* patternName(Texture::Pattern p)
{
  switch (p)
  {
    case Texture::Pattern::kChecker:
      return "checker";
    case Texture::Pattern::kStripes:
      return "stripes";
    case Texture::Pattern::kPlanks:
      return "planks";
    case Texture::Pattern::kBricks:
      return "bricks";
    case Texture::Pattern::kTiles:
      return "tiles";
    default:
      return "solid";
  }
}

std::string structureYaml(const Texture& t)
{
  std::string s;
  if (t.material())
    s += "joint: " + num(t.joint) + ", ";
  const std::pair<const char*, double> amounts[] = {{"variation", t.variation},
                                                    {"grain", t.grain},
                                                    {"speckle", t.speckle},
                                                    {"gradient", t.gradient},
                                                    {"shine", t.shine}};
  for (const auto& [key, value] : amounts)
    if (value > 0.0)
      s += std::string(key) + ": " + num(value) + ", ";
  if (!s.empty())
    s += "seed: " + std::to_string(t.seed) + ", ";
  return s;
}
}  // namespace

std::string textureYaml(const Texture& t)
{
  std::string s = "{";
  if (t.pattern != Texture::Pattern::kSolid)
  {
    s += std::string("pattern: ") + patternName(t.pattern) + ", ";
    s += "color2: " + colorYaml(t.color2) + ", cell: " + vec2(t.cell) + ", ";
    if (t.stripes_along_v)
      s += "horizontal: true, ";
    if (!t.offset.isZero())
      s += "offset: " + vec2(t.offset) + ", ";
  }
  s += structureYaml(t) + "color: " + colorYaml(t.color);
  if (!t.rects.empty())
  {
    s += ", rects: [";
    for (size_t k = 0; k < t.rects.size(); ++k)
      s += std::string(k ? ", " : "") + "{min: " + vec2(t.rects[k].min) + ", max: " + vec2(t.rects[k].max) +
           ", color: " + colorYaml(t.rects[k].color) + "}";
    s += "]";
  }
  return s + "}";
}

double WallSide::reserve(Rng& rng, double width)
{
  const double lo = 0.3, hi = length() - 0.3 - width;
  for (int attempt = 0; attempt < 30 && hi > lo; ++attempt)
  {
    const double u = rng.uniform(lo, hi);
    bool free = true;
    for (const auto& [a, b] : used)
      free = free && (u + width + 0.2 < a || u > b + 0.2);
    if (free)
    {
      used.emplace_back(u, u + width);
      return u;
    }
  }
  return -1.0;
}

std::string Scene::uniqueName(const std::string& base)
{
  std::string name = base;
  for (int k = 2; names_.count(name); ++k)
    name = base + "_" + std::to_string(k);
  names_.insert(name);
  return name;
}

void Scene::polygon(const std::string& name, const std::vector<Eigen::Vector3d>& points, const Texture& texture)
{
  out_ << "  - name: " << uniqueName(name) << "\n    polygon: [";
  for (size_t k = 0; k < points.size(); ++k)
    out_ << (k ? ", " : "") << vec3(points[k]);
  out_ << "]\n    texture: ";
  add(name.find("floor") != std::string::npos     ? Kind::kFloor
      : name.find("ceiling") != std::string::npos ? Kind::kCeiling
                                                  : Kind::kOther,
      texture);
}

void Scene::rectangle(const std::string& name, const Eigen::Vector3d& center, const Eigen::Vector3d& normal,
                      const Eigen::Vector2d& size, const Texture& texture)
{
  out_ << "  - name: " << uniqueName(name) << "\n    rectangle: {center: " << vec3(center)
       << ", normal: " << vec3(normal) << ", size: " << vec2(size);
  if (std::abs(normal.z()) > 0.9)
    out_ << ", up: [0, 1, 0]";
  out_ << "}\n    texture: ";
  add(Kind::kOther, texture);
}

void Scene::box(const std::string& name, const Box3& b, const Texture& texture, bool obstacle, double yaw_deg)
{
  out_ << "  - name: " << uniqueName(name) << "\n    box: {min: " << vec3(b.min) << ", max: " << vec3(b.max);
  if (yaw_deg != 0.0)
    out_ << ", yaw_deg: " << num(yaw_deg);
  out_ << "}\n    texture: ";
  add(Kind::kOther, texture);
  // A turned box: its footprint is bounded by the circumscribed square (conservative for the route).
  const Eigen::Vector2d lo = b.min.head<2>(), hi = b.max.head<2>();
  const Eigen::Vector2d c = 0.5 * (lo + hi);
  const double grow = yaw_deg != 0.0 ? 0.5 * (hi - lo).norm() - 0.5 * (hi - lo).minCoeff() : 0.0;
  const Eigen::Vector2d l = lo - Eigen::Vector2d::Constant(grow), h = hi + Eigen::Vector2d::Constant(grow);
  if (obstacle && b.min.z() < 1.3)
    plan.obstacles.push_back({l, Eigen::Vector2d(h.x(), l.y()), h, Eigen::Vector2d(l.x(), h.y())});
  solids.push_back({Eigen::Vector3d(l.x(), l.y(), b.min.z()), Eigen::Vector3d(h.x(), h.y(), b.max.z())});
  (void)c;
}

void Scene::wall(const std::string& name, const Eigen::Vector2d& from, const Eigen::Vector2d& to, double height,
                 const std::vector<Opening>& openings, const Texture& texture)
{
  out_ << "  - name: " << uniqueName(name) << "\n    wall: {from: " << vec2(from) << ", to: " << vec2(to)
       << ", height: " << num(height);
  if (!openings.empty())
  {
    out_ << ", openings: [";
    for (size_t k = 0; k < openings.size(); ++k)
      out_ << (k ? ", " : "") << "{offset: " << num(openings[k].offset) << ", width: " << num(openings[k].width)
           << ", height: " << num(openings[k].height) << ", sill: " << num(openings[k].sill) << "}";
    out_ << "]";
  }
  out_ << "}\n    texture: ";
  add(Kind::kWall, texture);
}

void Scene::add(Kind kind, const Texture& texture)
{
  entries_.push_back({out_.str(), kind, texture});
  out_.str("");
}

std::string Scene::surfaces(std::optional<uint64_t> materials_seed) const
{
  std::optional<Rng> rng;
  if (materials_seed)
    rng.emplace(*materials_seed, 0x6d6174ULL);
  std::string out;
  for (const Entry& e : entries_)
    out += e.head + textureYaml(rng ? dress(e.kind, e.texture, *rng) : e.texture) + "\n";
  return out;
}

// The plain texture as a material with natural structure: checker floors as ceramic or carpet tiles, striped (board)
// floors as planks with grain, ceilings as tiles, a quarter of the walls as brick, the others as paint under uneven
// light; fine speckle and a lighting gradient on everything else. The joints stay near the plain pattern's lines.
Texture Scene::dress(Kind kind, Texture t, Rng& rng)
{
  t.seed = static_cast<uint32_t>(rng.integer(0, 1 << 30));
  t.gradient = rng.uniform(0.08, 0.2);
  const bool checker = t.pattern == Texture::Pattern::kChecker;
  if (kind == Kind::kFloor && checker && rng.chance(0.65))
  {
    t.pattern = Texture::Pattern::kTiles;
    t.joint = rng.uniform(0.003, 0.006);
    t.color2 = rng.chance(0.5) ? Color(t.color * 0.55f) : Color(215, 212, 205);
    t.variation = 0.05;
    t.speckle = 0.12;
    t.shine = 0.15;  // glazed
  }
  else if (kind == Kind::kFloor && checker)  // carpet tiles
  {
    t.pattern = Texture::Pattern::kTiles;
    t.joint = 0.002;
    t.color2 = t.color * 0.85f;
    t.variation = 0.05;
    t.speckle = 0.6;
  }
  else if (kind == Kind::kFloor && t.pattern == Texture::Pattern::kStripes)  // boards
  {
    t.pattern = Texture::Pattern::kPlanks;
    t.cell = Eigen::Vector2d(rng.uniform(0.9, 1.8), t.cell.x() + t.cell.y());
    t.joint = 0.003;
    t.variation = 0.12;
    t.grain = rng.uniform(0.4, 0.8);
    t.shine = 0.08;  // varnish
  }
  else if (kind == Kind::kCeiling && checker)
  {
    t.pattern = Texture::Pattern::kTiles;
    t.joint = 0.012;  // the T-bar grid
    t.color2 = t.color * 0.82f;
    t.speckle = 0.15;
  }
  else if (kind == Kind::kWall && t.pattern == Texture::Pattern::kSolid && rng.chance(0.25))
  {
    t.pattern = Texture::Pattern::kBricks;
    t.color2 = rng.color({{200, 196, 186}, {170, 166, 160}}, 8);
    t.color = rng.color({{150, 70, 50}, {170, 100, 70}, {120, 60, 48}, {190, 150, 110}}, 10);
    t.cell = Eigen::Vector2d(0.225, 0.075);
    t.offset = Eigen::Vector2d(rng.uniform(0.0, 0.225), rng.uniform(0.0, 0.075));
    t.joint = 0.01;
    t.variation = 0.15;
    t.speckle = 0.4;
  }
  else if (kind == Kind::kWall)
    t.gradient = rng.uniform(0.2, 0.35);  // paint: lit unevenly
  else if (t.pattern == Texture::Pattern::kSolid)
    t.speckle = 0.1;  // fabric, wood, laminate
  return t;
}

void Scene::onWall(const std::string& name, const WallSide& side, double u, double v, const Eigen::Vector2d& size,
                   const Texture& texture, double lift)
{
  const Eigen::Vector2d p = side.at(u) + lift * side.inward;
  rectangle(name, Eigen::Vector3d(p.x(), p.y(), v), Eigen::Vector3d(side.inward.x(), side.inward.y(), 0.0), size,
            texture);
}

}  // namespace generator
}  // namespace simulation
}  // namespace insitu_calibration
