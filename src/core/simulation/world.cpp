#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/simulation/world_limits.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <regex>
#include <set>

#include "insitu_calibration/io/atomic_file.h"
#include "insitu_calibration/geometry/optical_frame.h"
#include "io/yaml_util.h"

namespace insitu_calibration
{
namespace simulation
{
namespace
{
constexpr double kDegToRad = M_PI / 180.0;
constexpr double kPlanarityToleranceM = 1e-3;

Error parseError(const std::string& where, const std::string& what)
{
  return Error(ErrorCode::kParseError, where + ": " + what);
}
Error invalid(const std::string& where, const std::string& what)
{
  return Error(ErrorCode::kInvalidInput, where + ": " + what);
}

std::string fmt(double value)
{
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%g", value);
  return buffer;
}

// Reads a YAML map: required and optional keys, refusing keys it does not know (typos would silently fall back to
// defaults otherwise).
class MapReader
{
public:
  MapReader(const yaml_util::YamlNode& node, std::string where) : node_(node), where_(std::move(where)) {}

  Status check(const std::set<std::string>& allowed) const
  {
    if (!node_ || !node_.IsMap())
      return parseError(where_, "expected a map of keys");
    for (const auto& entry : node_)
    {
      const std::string key = entry.first.as<std::string>();
      if (!allowed.count(key))
      {
        std::string list;
        for (const auto& a : allowed)
          list += (list.empty() ? "" : ", ") + a;
        return parseError(where_, "unknown key '" + key + "' (known keys: " + list + ")");
      }
    }
    return Success{};
  }
  bool has(const std::string& key) const { return static_cast<bool>(node_[key]); }
  yaml_util::YamlNode operator[](const std::string& key) const { return node_[key]; }
  std::string at(const std::string& key) const { return where_ + "." + key; }
  const std::string& where() const { return where_; }

  Status require(const std::string& key) const
  {
    if (!node_[key])
      return parseError(where_, "missing key '" + key + "'");
    return Success{};
  }
  Expected<double> number(const std::string& key) const
  {
    if (const Status s = require(key); !s)
      return s.error();
    return yaml_util::toDouble(node_[key], at(key));
  }
  Expected<double> number(const std::string& key, double fallback) const
  {
    return has(key) ? yaml_util::toDouble(node_[key], at(key)) : Expected<double>(fallback);
  }
  Expected<double> positive(const std::string& key, std::optional<double> fallback = std::nullopt) const
  {
    const auto v = fallback ? number(key, *fallback) : number(key);
    if (v && !(*v > 0.0))
      return invalid(at(key), "must be positive (got " + fmt(*v) + ")");
    return v;
  }
  Expected<int> integer(const std::string& key, std::optional<int> fallback = std::nullopt) const
  {
    if (!has(key))
    {
      if (fallback)
        return *fallback;
      return parseError(where_, "missing key '" + key + "'");
    }
    return yaml_util::toInt(node_[key], at(key));
  }
  Expected<bool> boolean(const std::string& key, bool fallback) const
  {
    if (!has(key))
      return fallback;
    try
    {
      return node_[key].as<bool>();
    }
    catch (const YAML::Exception&)
    {
      return parseError(at(key), "expected true or false");
    }
  }
  Expected<std::string> text(const std::string& key) const
  {
    if (const Status s = require(key); !s)
      return s.error();
    if (!node_[key].IsScalar())
      return parseError(at(key), "expected a string");
    return node_[key].as<std::string>();
  }
  template <int N>
  Expected<Eigen::Matrix<double, N, 1>> vector(const std::string& key) const
  {
    if (const Status s = require(key); !s)
      return s.error();
    return yaml_util::toVector<N>(node_[key], at(key));
  }

private:
  yaml_util::YamlNode node_;
  std::string where_;
};

#define TRY_ASSIGN(lhs, expr)        \
  do                                 \
  {                                  \
    auto _value = (expr);            \
    if (!_value)                     \
      return _value.error();         \
    lhs = std::move(_value.value()); \
  } while (false)

#define TRY(expr)                \
  do                             \
  {                              \
    const auto _status = (expr); \
    if (!_status)                \
      return _status.error();    \
  } while (false)

Expected<Color> parseColor(const yaml_util::YamlNode& node, const std::string& where)
{
  const auto v = yaml_util::toNumbers(node, where, 3);
  if (!v)
    return v.error();
  for (double c : *v)
    if (c < 0.0 || c > 255.0)
      return invalid(where, "colour components must be in 0..255 (got " + fmt(c) + ")");
  return Color(static_cast<float>((*v)[0]), static_cast<float>((*v)[1]), static_cast<float>((*v)[2]));
}

Expected<Eigen::Vector2d> parsePair(const yaml_util::YamlNode& node, const std::string& where)
{
  if (node && node.IsScalar())
  {
    const auto v = yaml_util::toDouble(node, where);
    if (!v)
      return v.error();
    return Eigen::Vector2d(*v, *v);
  }
  return yaml_util::toVector<2>(node, where);
}

Expected<Texture> parseTexture(const yaml_util::YamlNode& node, const std::string& where)
{
  Texture texture;
  if (!node)
    return texture;
  const MapReader m(node, where);
  TRY(m.check({"pattern", "color", "color2", "cell", "horizontal", "offset", "rects", "joint", "variation", "grain",
               "speckle", "gradient", "shine", "seed"}));
  std::string pattern = "solid";
  if (m.has("pattern"))
    TRY_ASSIGN(pattern, m.text("pattern"));
  if (pattern == "solid")
    texture.pattern = Texture::Pattern::kSolid;
  else if (pattern == "checker")
    texture.pattern = Texture::Pattern::kChecker;
  else if (pattern == "planks")
    texture.pattern = Texture::Pattern::kPlanks;
  else if (pattern == "bricks")
    texture.pattern = Texture::Pattern::kBricks;
  else if (pattern == "tiles")
    texture.pattern = Texture::Pattern::kTiles;
  else if (pattern == "stripes")
    texture.pattern = Texture::Pattern::kStripes;
  else
    return invalid(m.at("pattern"),
                   "unknown pattern '" + pattern + "' (solid, checker, stripes, planks, bricks or tiles)");
  if (m.has("color"))
    TRY_ASSIGN(texture.color, parseColor(m["color"], m.at("color")));
  if (m.has("color2"))
    TRY_ASSIGN(texture.color2, parseColor(m["color2"], m.at("color2")));
  if (m.has("cell"))
  {
    TRY_ASSIGN(texture.cell, parsePair(m["cell"], m.at("cell")));
    if (!(texture.cell.minCoeff() > 0.0))
      return invalid(m.at("cell"), "cell sizes must be positive");
  }
  TRY_ASSIGN(texture.stripes_along_v, m.boolean("horizontal", false));
  TRY_ASSIGN(texture.joint, m.number("joint", texture.joint));
  TRY_ASSIGN(texture.variation, m.number("variation", 0.0));
  TRY_ASSIGN(texture.grain, m.number("grain", 0.0));
  TRY_ASSIGN(texture.speckle, m.number("speckle", 0.0));
  TRY_ASSIGN(texture.gradient, m.number("gradient", 0.0));
  TRY_ASSIGN(texture.shine, m.number("shine", 0.0));
  int seed = 0;
  TRY_ASSIGN(seed, m.integer("seed", 0));
  if (seed < 0)
    return invalid(m.at("seed"), "must not be negative");
  texture.seed = static_cast<uint32_t>(seed);
  if (m.has("offset"))
    TRY_ASSIGN(texture.offset, parsePair(m["offset"], m.at("offset")));
  if (m.has("rects"))
  {
    const yaml_util::YamlNode rects = m["rects"];
    if (!rects.IsSequence())
      return parseError(m.at("rects"), "expected a list of {min, max, color}");
    if (rects.size() > 1000)
      return invalid(m.at("rects"), "at most 1000 rectangles per texture");
    for (size_t i = 0; i < rects.size(); ++i)
    {
      const MapReader r(rects[i], m.at("rects") + "[" + std::to_string(i) + "]");
      TRY(r.check({"min", "max", "color"}));
      TextureRect rect;
      TRY_ASSIGN(rect.min, r.vector<2>("min"));
      TRY_ASSIGN(rect.max, r.vector<2>("max"));
      TRY(r.require("color"));
      TRY_ASSIGN(rect.color, parseColor(r["color"], r.at("color")));
      if (!(rect.max.x() > rect.min.x() && rect.max.y() > rect.min.y()))
        return invalid(r.where(), "max must be greater than min in u and v");
      texture.rects.push_back(rect);
    }
  }
  return texture;
}

Expected<std::vector<Eigen::Vector3d>> parseRing(const yaml_util::YamlNode& node, const std::string& where)
{
  if (!node || !node.IsSequence())
    return parseError(where, "expected a list of [x, y, z] vertices");
  std::vector<Eigen::Vector3d> ring;
  for (size_t i = 0; i < node.size(); ++i)
  {
    const auto v = yaml_util::toVector<3>(node[i], where + "[" + std::to_string(i) + "]");
    if (!v)
      return v.error();
    ring.push_back(*v);
  }
  return ring;
}

Surface makeQuad(const std::string& name, const Eigen::Vector3d& origin, const Eigen::Vector3d& u,
                 const Eigen::Vector3d& v, const Texture& texture)
{
  Surface s;
  s.name = name;
  s.rings = {{origin, origin + u, origin + u + v, origin + v}};
  s.texture = texture;
  s.origin = origin;
  s.axis_u = u.normalized();
  s.axis_v = v.normalized();
  return s;
}

Expected<std::vector<Surface>> parsePolygon(const MapReader& m, const std::string& where, const std::string& name,
                                            const Texture& texture)
{
  Surface s;
  s.name = name;
  s.texture = texture;
  std::vector<Eigen::Vector3d> ring;
  TRY_ASSIGN(ring, parseRing(m["polygon"], where + ".polygon"));
  s.rings.push_back(ring);
  if (m.has("holes"))
  {
    if (!m["holes"].IsSequence())
      return parseError(where + ".holes", "expected a list of vertex lists");
    for (size_t h = 0; h < m["holes"].size(); ++h)
    {
      TRY_ASSIGN(ring, parseRing(m["holes"][h], where + ".holes[" + std::to_string(h) + "]"));
      s.rings.push_back(ring);
    }
  }
  return std::vector<Surface>{s};
}

Expected<std::vector<Surface>> parseRectangle(const MapReader& m, const std::string& where, const std::string& name,
                                              const Texture& texture)
{
  const MapReader r(m["rectangle"], where + ".rectangle");
  TRY(r.check({"center", "normal", "up", "size"}));
  Eigen::Vector3d center, normal, up = Eigen::Vector3d::UnitZ();
  Eigen::Vector2d size;
  TRY_ASSIGN(center, r.vector<3>("center"));
  TRY_ASSIGN(normal, r.vector<3>("normal"));
  if (r.has("up"))
    TRY_ASSIGN(up, r.vector<3>("up"));
  TRY(r.require("size"));
  TRY_ASSIGN(size, parsePair(r["size"], r.at("size")));
  if (!(size.minCoeff() > 0.0))
    return invalid(r.at("size"), "width and height must be positive");
  if (normal.norm() < 1e-9)
    return invalid(r.at("normal"), "the normal is zero");
  normal.normalize();
  if (!r.has("up") && std::abs(normal.z()) > 0.99)
    up = Eigen::Vector3d::UnitY();
  const Eigen::Vector3d right = up.cross(normal);
  if (right.norm() < 1e-6)
    return invalid(r.at("up"), "'up' is parallel to the normal");
  const Eigen::Vector3d u = right.normalized();
  const Eigen::Vector3d v = normal.cross(u);
  return std::vector<Surface>{
      makeQuad(name, center - 0.5 * size.x() * u - 0.5 * size.y() * v, size.x() * u, size.y() * v, texture)};
}

Expected<std::vector<Surface>> parseBox(const MapReader& m, const std::string& where, const std::string& name,
                                        const Texture& texture)
{
  const MapReader b(m["box"], where + ".box");
  TRY(b.check({"min", "max", "yaw_deg", "bottom"}));
  Eigen::Vector3d lo, hi;
  TRY_ASSIGN(lo, b.vector<3>("min"));
  TRY_ASSIGN(hi, b.vector<3>("max"));
  double yaw = 0.0;
  TRY_ASSIGN(yaw, b.number("yaw_deg", 0.0));
  bool bottom = false;
  TRY_ASSIGN(bottom, b.boolean("bottom", false));
  if (!((hi - lo).minCoeff() > 0.0))
    return invalid(b.where(), "max must be greater than min in x, y and z");
  const Eigen::Vector3d c = 0.5 * (lo + hi);
  const Eigen::Vector3d e = hi - lo;
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(yaw * kDegToRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d ex = rot * Eigen::Vector3d(e.x(), 0, 0);
  const Eigen::Vector3d ey = rot * Eigen::Vector3d(0, e.y(), 0);
  const Eigen::Vector3d ez(0, 0, e.z());
  const Eigen::Vector3d p000 = c - 0.5 * (ex + ey + ez);
  // Side faces: u horizontal (counter-clockwise seen from above), v up, normals outwards.
  std::vector<Surface> out;
  out.push_back(makeQuad(name + "/-y", p000, ex, ez, texture));
  out.push_back(makeQuad(name + "/+x", p000 + ex, ey, ez, texture));
  out.push_back(makeQuad(name + "/+y", p000 + ex + ey, -ex, ez, texture));
  out.push_back(makeQuad(name + "/-x", p000 + ey, -ey, ez, texture));
  out.push_back(makeQuad(name + "/top", p000 + ez, ex, ey, texture));
  if (bottom)
    out.push_back(makeQuad(name + "/bottom", p000 + ey, ex, -ey, texture));
  return out;
}

// A door or window in a wall: along the wall from its start, above its base (m).
struct WallOpening
{
  double offset, width, height, sill;
};

// The wall's openings, sorted along it; each strictly inside the wall and none overlapping.
Expected<std::vector<WallOpening>> parseOpenings(const MapReader& w, double length, double height)
{
  std::vector<WallOpening> openings;
  if (!w.has("openings"))
    return openings;
  if (!w["openings"].IsSequence())
    return parseError(w.at("openings"), "expected a list of {offset, width, height, sill}");
  for (size_t i = 0; i < w["openings"].size(); ++i)
  {
    const MapReader o(w["openings"][i], w.at("openings") + "[" + std::to_string(i) + "]");
    TRY(o.check({"offset", "width", "height", "sill"}));
    WallOpening op{};
    TRY_ASSIGN(op.offset, o.number("offset"));
    TRY_ASSIGN(op.width, o.positive("width"));
    TRY_ASSIGN(op.height, o.positive("height"));
    TRY_ASSIGN(op.sill, o.number("sill", 0.0));
    if (op.offset <= 0.0 || op.offset + op.width >= length || op.sill < 0.0 || op.sill + op.height >= height)
      return invalid(o.where(), "the opening must lie strictly inside the wall (length " + fmt(length) + " m, height " +
                                    fmt(height) + " m)");
    openings.push_back(op);
  }
  std::sort(openings.begin(), openings.end(),
            [](const WallOpening& a, const WallOpening& b) { return a.offset < b.offset; });
  for (size_t i = 1; i < openings.size(); ++i)
    if (openings[i].offset <= openings[i - 1].offset + openings[i - 1].width)
      return invalid(w.where(), "openings overlap");
  return openings;
}

// A vertical wall from `from` to `to` (its base at height base): a doorway (sill 0) is a notch in the outline, a
// window a hole.
Surface makeWall(const std::string& name, const Texture& texture, const Eigen::Vector2d& from,
                 const Eigen::Vector2d& to, double base, double height, const std::vector<WallOpening>& openings)
{
  const double length = (to - from).norm();
  const Eigen::Vector3d u(((to - from) / length).x(), ((to - from) / length).y(), 0.0);
  const Eigen::Vector3d origin(from.x(), from.y(), base);
  auto at = [&](double s, double h) -> Eigen::Vector3d { return origin + s * u + h * Eigen::Vector3d::UnitZ(); };
  Surface s;
  s.name = name;
  s.texture = texture;
  std::vector<Eigen::Vector3d> outline{at(0, 0)};
  std::vector<std::vector<Eigen::Vector3d>> holes;
  for (const WallOpening& op : openings)
  {
    if (op.sill == 0.0)
    {
      outline.push_back(at(op.offset, 0));
      outline.push_back(at(op.offset, op.height));
      outline.push_back(at(op.offset + op.width, op.height));
      outline.push_back(at(op.offset + op.width, 0));
    }
    else
    {
      holes.push_back({at(op.offset, op.sill), at(op.offset + op.width, op.sill),
                       at(op.offset + op.width, op.sill + op.height), at(op.offset, op.sill + op.height)});
    }
  }
  outline.push_back(at(length, 0));
  outline.push_back(at(length, height));
  outline.push_back(at(0, height));
  s.rings.push_back(outline);
  for (auto& h : holes)
    s.rings.push_back(h);
  s.origin = origin;
  s.axis_u = u;
  s.axis_v = Eigen::Vector3d::UnitZ();
  return s;
}

Expected<std::vector<Surface>> parseWall(const MapReader& m, const std::string& where, const std::string& name,
                                         const Texture& texture)
{
  const MapReader w(m["wall"], where + ".wall");
  TRY(w.check({"from", "to", "height", "base", "openings"}));
  Eigen::Vector2d from, to;
  double height = 0.0, base = 0.0;
  TRY_ASSIGN(from, w.vector<2>("from"));
  TRY_ASSIGN(to, w.vector<2>("to"));
  TRY_ASSIGN(height, w.positive("height"));
  TRY_ASSIGN(base, w.number("base", 0.0));
  const double length = (to - from).norm();
  if (!(length > 1e-6))
    return invalid(w.where(), "'from' and 'to' are the same point");
  std::vector<WallOpening> openings;
  TRY_ASSIGN(openings, parseOpenings(w, length, height));
  return std::vector<Surface>{makeWall(name, texture, from, to, base, height, openings)};
}

// One entry of surfaces: a polygon (with holes), a rectangle, a box (its 5 or 6 faces) or a wall (with openings).
Expected<std::vector<Surface>> parseSurface(const yaml_util::YamlNode& node, size_t index, const std::string& source)
{
  std::string where = source + ": surfaces[" + std::to_string(index) + "]";
  const MapReader m(node, where);
  TRY(m.check({"name", "polygon", "holes", "rectangle", "box", "wall", "texture"}));
  std::string name;
  TRY_ASSIGN(name, m.text("name"));
  where += " '" + name + "'";
  Texture texture;
  TRY_ASSIGN(texture, parseTexture(m["texture"], where + ".texture"));
  const int shapes = m.has("polygon") + m.has("rectangle") + m.has("box") + m.has("wall");
  if (shapes != 1)
    return parseError(where, shapes == 0 ? "missing key: one of 'polygon', 'rectangle', 'box' or 'wall'"
                                         : "give only one of 'polygon', 'rectangle', 'box' or 'wall'");
  if (m.has("holes") && !m.has("polygon"))
    return parseError(where, "'holes' belongs to a 'polygon'");
  std::vector<Surface> out;
  TRY_ASSIGN(out, m.has("polygon")     ? parsePolygon(m, where, name, texture)
                  : m.has("rectangle") ? parseRectangle(m, where, name, texture)
                  : m.has("box")       ? parseBox(m, where, name, texture)
                                       : parseWall(m, where, name, texture));
  // A polygon's texture frame comes from its vertices; the other shapes set their own.
  const bool frame_set = !m.has("polygon");
  for (Surface& surface : out)
  {
    const Status s = finalizeSurface(surface, frame_set);
    if (!s)
      return Error(s.error().code(), where + ": " + s.error().message());
  }
  return out;
}

Expected<Route> parseRoute(const yaml_util::YamlNode& node, const std::string& where)
{
  const MapReader m(node, where);
  TRY(m.check({"waypoints", "speed", "turn_rate_deg", "loop"}));
  Route route;
  TRY(m.require("waypoints"));
  if (!m["waypoints"].IsSequence())
    return parseError(m.at("waypoints"), "expected a list of [x, y]");
  for (size_t i = 0; i < m["waypoints"].size(); ++i)
  {
    Eigen::Vector2d p;
    TRY_ASSIGN(p, yaml_util::toVector<2>(m["waypoints"][i], m.at("waypoints") + "[" + std::to_string(i) + "]"));
    if (!route.waypoints.empty() && (p - route.waypoints.back()).norm() < 1e-3)
      return invalid(m.at("waypoints") + "[" + std::to_string(i) + "]", "repeats the previous waypoint");
    route.waypoints.push_back(p);
  }
  if (route.waypoints.size() < 2)
    return invalid(m.at("waypoints"), "at least 2 waypoints are needed");
  TRY_ASSIGN(route.speed, m.positive("speed", route.speed));
  TRY_ASSIGN(route.turn_rate_deg, m.positive("turn_rate_deg", route.turn_rate_deg));
  TRY_ASSIGN(route.loop, m.boolean("loop", route.loop));
  return route;
}

Expected<XtionConfig> parseXtion(const yaml_util::YamlNode& node, const std::string& where)
{
  XtionConfig x;
  if (!node)
    return x;
  const MapReader m(node, where);
  TRY(m.check({"width", "height", "fx", "fy", "cx", "cy", "mount_height", "mount_forward", "tilt_deg",
               "rgb_noise_sigma", "supersampling", "depth"}));
  TRY_ASSIGN(x.width, m.integer("width", x.width));
  TRY_ASSIGN(x.height, m.integer("height", x.height));
  if (x.width <= 0 || x.height <= 0)
    return invalid(where, "width and height must be positive");
  TRY_ASSIGN(x.intrinsics.fx, m.positive("fx", x.intrinsics.fx));
  TRY_ASSIGN(x.intrinsics.fy, m.positive("fy", x.intrinsics.fy));
  TRY_ASSIGN(x.intrinsics.cx, m.number("cx", 0.5 * x.width - 0.5));
  TRY_ASSIGN(x.intrinsics.cy, m.number("cy", 0.5 * x.height - 0.5));
  TRY_ASSIGN(x.mount_height_m, m.positive("mount_height", x.mount_height_m));
  TRY_ASSIGN(x.mount_forward_m, m.number("mount_forward", x.mount_forward_m));
  TRY_ASSIGN(x.tilt_deg, m.number("tilt_deg", x.tilt_deg));
  if (std::abs(x.tilt_deg) >= 89.0)
    return invalid(m.at("tilt_deg"), "must be within +-89 degrees");
  TRY_ASSIGN(x.rgb_noise_sigma, m.number("rgb_noise_sigma", x.rgb_noise_sigma));
  TRY_ASSIGN(x.supersampling, m.integer("supersampling", x.supersampling));
  if (x.supersampling < 1 || x.supersampling > 8)
    return invalid(m.at("supersampling"), "must be 1..8");
  if (x.rgb_noise_sigma < 0.0)
    return invalid(m.at("rgb_noise_sigma"), "must not be negative");
  if (m.has("depth"))
  {
    const MapReader d(m["depth"], m.at("depth"));
    TRY(d.check({"sigma_coefficient", "baseline", "disparity_subpixel", "min_range", "max_range", "max_incidence_deg",
                 "correlation_px"}));
    DepthSensorConfig& c = x.depth;
    TRY_ASSIGN(c.sigma_coefficient, d.number("sigma_coefficient", c.sigma_coefficient));
    TRY_ASSIGN(c.baseline_m, d.positive("baseline", c.baseline_m));
    TRY_ASSIGN(c.disparity_subpixel, d.number("disparity_subpixel", c.disparity_subpixel));
    TRY_ASSIGN(c.min_range_m, d.number("min_range", c.min_range_m));
    TRY_ASSIGN(c.max_range_m, d.positive("max_range", c.max_range_m));
    TRY_ASSIGN(c.max_incidence_deg, d.positive("max_incidence_deg", c.max_incidence_deg));
    TRY_ASSIGN(c.correlation_px, d.number("correlation_px", c.correlation_px));
    if (c.sigma_coefficient < 0.0 || c.disparity_subpixel < 0.0 || c.correlation_px < 0.0 || c.min_range_m < 0.0 ||
        c.max_range_m <= c.min_range_m || c.max_range_m > 65.0 || c.max_incidence_deg > 90.0)
      return invalid(d.where(),
                     "sigma_coefficient, disparity_subpixel, correlation_px and min_range must not be "
                     "negative, min_range < max_range <= 65 m, max_incidence_deg <= 90");
  }
  return x;
}

// Keys absent from the block keep the values of base (the world's default for its kind of camera).
Expected<CameraAppearance> parseCameraAppearance(const yaml_util::YamlNode& node, const std::string& where,
                                                 const CameraAppearance& base)
{
  CameraAppearance a = base;
  if (!node)
    return a;
  const MapReader m(node, where);
  TRY(m.check({"blur_sigma_px", "vignetting", "exposure", "white_balance", "jpeg_quality"}));
  TRY_ASSIGN(a.blur_sigma_px, m.number("blur_sigma_px", a.blur_sigma_px));
  TRY_ASSIGN(a.vignetting, m.number("vignetting", a.vignetting));
  TRY_ASSIGN(a.exposure, m.number("exposure", a.exposure));
  if (m.has("white_balance"))
    TRY_ASSIGN(a.white_balance, m.vector<3>("white_balance"));
  TRY_ASSIGN(a.jpeg_quality, m.integer("jpeg_quality", a.jpeg_quality));
  return a;
}

Expected<Appearance> parseAppearance(const yaml_util::YamlNode& node, const std::string& where)
{
  Appearance a;
  if (!node)
    return a;
  const MapReader m(node, where);
  TRY(m.check({"xtion_rgb", "fixed_cameras", "depth"}));
  TRY_ASSIGN(a.xtion_rgb, parseCameraAppearance(m["xtion_rgb"], m.at("xtion_rgb"), a.xtion_rgb));
  TRY_ASSIGN(a.fixed_cameras, parseCameraAppearance(m["fixed_cameras"], m.at("fixed_cameras"), a.fixed_cameras));
  if (m.has("depth"))
  {
    const MapReader d(m["depth"], m.at("depth"));
    TRY(d.check(
        {"flying_pixels", "flying_step_m", "low_frequency_coefficient", "low_frequency_px", "misregistration_px"}));
    DepthAppearance& z = a.depth;
    TRY_ASSIGN(z.flying_pixels, d.number("flying_pixels", z.flying_pixels));
    TRY_ASSIGN(z.flying_step_m, d.number("flying_step_m", z.flying_step_m));
    TRY_ASSIGN(z.low_frequency_coefficient, d.number("low_frequency_coefficient", z.low_frequency_coefficient));
    TRY_ASSIGN(z.low_frequency_px, d.number("low_frequency_px", z.low_frequency_px));
    if (d.has("misregistration_px"))
      TRY_ASSIGN(z.misregistration_px, d.vector<2>("misregistration_px"));
  }
  return a;
}

// A fixed camera's division model: lambda or the corner displacement it makes, about the principal point unless
// given; every pixel must keep a ray.
Expected<DivisionModel> parseFixedDistortion(const MapReader& n, const std::string& where,
                                             const Eigen::Vector2d& principal_point, int width, int height)
{
  DivisionModel dist;
  dist.center = principal_point;
  if (n.has("distortion_center"))
    TRY_ASSIGN(dist.center, n.vector<2>("distortion_center"));
  if (n.has("lambda") && n.has("corner_displacement_px"))
    return parseError(where, "give 'lambda' or 'corner_displacement_px', not both");
  if (n.has("lambda"))
    TRY_ASSIGN(dist.lambda, n.number("lambda"));
  else if (n.has("corner_displacement_px"))
  {
    double displacement = 0.0;
    TRY_ASSIGN(displacement, n.number("corner_displacement_px"));
    dist.lambda = lambdaForCornerDisplacement(dist.center, width, height, displacement);
  }
  // Every pixel must have a ray: 1 + lambda r^2 > 0 over the image.
  for (double x : {0.0, width - 1.0})
    for (double y : {0.0, height - 1.0})
      if (!(1.0 + dist.lambda * (Eigen::Vector2d(x, y) - dist.center).squaredNorm() > 0.05))
        return invalid(where, "lambda " + fmt(dist.lambda) + " is too strong: the image corners have no ray");
  return dist;
}

// A fixed camera's rotation (world from optical frame): from look_at and roll_deg, or a quaternion.
Expected<Eigen::Matrix3d> parseFixedOrientation(const MapReader& n, const std::string& where,
                                                const Eigen::Vector3d& position)
{
  if (n.has("look_at") == n.has("orientation"))
    return parseError(where, "give exactly one of 'look_at' ([x, y, z] in map) or 'orientation' ([qx, qy, qz, qw])");
  if (n.has("look_at"))
  {
    Eigen::Vector3d target;
    TRY_ASSIGN(target, n.vector<3>("look_at"));
    double roll = 0.0;
    TRY_ASSIGN(roll, n.number("roll_deg", 0.0));
    const auto rotation = opticalRotationLookingAlong(target - position, roll * kDegToRad);
    if (!((target - position).norm() > 1e-6) || !rotation)
      return invalid(n.at("look_at"), "the camera must not look straight up or down (use 'orientation')");
    return *rotation;
  }
  Eigen::Vector4d q;
  TRY_ASSIGN(q, n.vector<4>("orientation"));
  if (!(q.norm() > 1e-9))
    return invalid(n.at("orientation"), "the quaternion is zero");
  return Eigen::Matrix3d(Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix());
}

// When and how a fixed camera takes its images: rate, phase, supersampling, noise.
Status parseFixedCapture(const MapReader& n, size_t index, SimulatedFixedCamera& c)
{
  TRY_ASSIGN(c.rate_hz, n.positive("rate", c.rate_hz));
  TRY_ASSIGN(c.phase_s, n.number("phase", 0.05 * static_cast<double>(index + 1)));
  if (c.phase_s < 0.0)
    return invalid(n.at("phase"), "must not be negative");
  TRY_ASSIGN(c.supersampling, n.integer("supersampling", c.supersampling));
  if (c.supersampling < 1 || c.supersampling > 8)
    return invalid(n.at("supersampling"), "must be 1..8");
  if (n.has("noise"))
  {
    const MapReader z(n["noise"], n.at("noise"));
    TRY(z.check({"read_sigma", "shot_gain"}));
    TRY_ASSIGN(c.noise.read_sigma, z.number("read_sigma", c.noise.read_sigma));
    TRY_ASSIGN(c.noise.shot_gain, z.number("shot_gain", c.noise.shot_gain));
    if (c.noise.read_sigma < 0.0 || c.noise.shot_gain < 0.0)
      return invalid(z.where(), "noise parameters must not be negative");
  }
  return Success{};
}

Expected<SimulatedFixedCamera> parseFixedCamera(const yaml_util::YamlNode& node, size_t index,
                                                const std::string& source, const CameraAppearance& appearance)
{
  std::string where = source + ": fixed_cameras[" + std::to_string(index) + "]";
  const MapReader m(node, where);
  TRY(m.check({"name",
               "width",
               "height",
               "fx",
               "fy",
               "cx",
               "cy",
               "skew",
               "lambda",
               "corner_displacement_px",
               "distortion_center",
               "position",
               "look_at",
               "roll_deg",
               "orientation",
               "rate",
               "phase",
               "noise",
               "supersampling",
               "appearance"}));
  SimulatedFixedCamera c;
  TRY_ASSIGN(c.name, m.text("name"));
  where += " '" + c.name + "'";
  static const std::regex valid_name("[A-Za-z][A-Za-z0-9_]*");
  if (!std::regex_match(c.name, valid_name))
    return invalid(where, "the name must be a ROS name: a letter, then letters, digits or '_'");
  const MapReader n(node, where);
  TRY_ASSIGN(c.width, n.integer("width"));
  TRY_ASSIGN(c.height, n.integer("height"));
  if (c.width <= 0 || c.height <= 0)
    return invalid(where, "width and height must be positive (got " + std::to_string(c.width) + "x" +
                              std::to_string(c.height) + ")");
  Intrinsics in;
  TRY_ASSIGN(in.fx, n.positive("fx"));
  TRY_ASSIGN(in.fy, n.positive("fy", in.fx));
  TRY_ASSIGN(in.cx, n.number("cx", 0.5 * c.width - 0.5));
  TRY_ASSIGN(in.cy, n.number("cy", 0.5 * c.height - 0.5));
  TRY_ASSIGN(in.skew, n.number("skew", 0.0));
  DivisionModel dist;
  TRY_ASSIGN(dist, parseFixedDistortion(n, where, in.principalPoint(), c.width, c.height));
  Eigen::Vector3d position;
  TRY_ASSIGN(position, n.vector<3>("position"));
  Eigen::Matrix3d world_from_camera;
  TRY_ASSIGN(world_from_camera, parseFixedOrientation(n, where, position));
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = world_from_camera;
  pose.translation() = position;
  c.camera = CameraModel(in, dist, CameraPose::fromWorldFromCamera(pose));
  TRY(parseFixedCapture(n, index, c));
  TRY_ASSIGN(c.appearance, parseCameraAppearance(n["appearance"], n.at("appearance"), appearance));
  return c;
}

Expected<Lighting> parseLighting(const yaml_util::YamlNode& node, const std::string& where)
{
  Lighting l;
  if (!node)
    return l;
  const MapReader m(node, where);
  TRY(m.check({"ambient", "diffuse", "direction"}));
  TRY_ASSIGN(l.ambient, m.number("ambient", l.ambient));
  TRY_ASSIGN(l.diffuse, m.number("diffuse", l.diffuse));
  if (m.has("direction"))
  {
    TRY_ASSIGN(l.direction, m.vector<3>("direction"));
    if (!(l.direction.norm() > 1e-9))
      return invalid(m.at("direction"), "the direction is zero");
    l.direction.normalize();
  }
  if (l.ambient < 0.0 || l.diffuse < 0.0 || l.ambient + l.diffuse > 1.5)
    return invalid(where, "ambient and diffuse must not be negative, and their sum at most 1.5");
  return l;
}

}  // namespace

Color Texture::basePattern(double u, double v, int* region) const
{
  switch (pattern)
  {
    case Pattern::kSolid:
      *region = 0;
      return color;
    case Pattern::kChecker: {
      const long i = static_cast<long>(std::floor((u - offset.x()) / cell.x()));
      const long j = static_cast<long>(std::floor((v - offset.y()) / cell.y()));
      *region = static_cast<int>((i + j) & 1);
      return *region ? color2 : color;
    }
    case Pattern::kStripes: {
      const double w = stripes_along_v ? v - offset.y() : u - offset.x();
      const double period = cell.x() + cell.y();
      const double m = w - std::floor(w / period) * period;
      *region = m < cell.x() ? 0 : 1;
      return *region ? color2 : color;
    }
    case Pattern::kPlanks:
    case Pattern::kBricks:
    case Pattern::kTiles: {
      Eigen::Vector2i unit;
      *region = materialRegion(u, v, &unit);
      return *region ? color2 : color;
    }
  }
  *region = 0;
  return color;
}

Color Texture::sample(double u, double v, int* region) const
{
  Color c;
  *region = -1;
  for (size_t i = rects.size(); i-- > 0 && *region < 0;)
  {
    const TextureRect& r = rects[i];
    if (u >= r.min.x() && u < r.max.x() && v >= r.min.y() && v < r.max.y())
    {
      *region = 2 + static_cast<int>(i);
      c = r.color;
    }
  }
  if (*region < 0)
    c = basePattern(u, v, region);
  if (variation == 0.0 && grain == 0.0 && speckle == 0.0 && gradient == 0.0)
    return c;
  return (c * structure(u, v, *region)).cwiseMin(255.0f);
}

bool Surface::contains(const Eigen::Vector2d& p) const
{
  bool inside = false;
  for (const auto& ring : rings_uv)
  {
    const size_t n = ring.size();
    for (size_t i = 0, j = n - 1; i < n; j = i++)
    {
      const Eigen::Vector2d& a = ring[i];
      const Eigen::Vector2d& b = ring[j];
      if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
        inside = !inside;
    }
  }
  return inside;
}

double Surface::distance(const Eigen::Vector3d& world) const
{
  const double plane = normal.dot(world) - offset;
  const Eigen::Vector2d p = toSurface(world);
  if (contains(p))
    return std::abs(plane);
  double best = std::numeric_limits<double>::infinity();
  for (const auto& ring : rings_uv)
    for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
    {
      const Eigen::Vector2d ab = ring[i] - ring[j];
      const double t = std::clamp((p - ring[j]).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
      best = std::min(best, (p - (ring[j] + t * ab)).squaredNorm());
    }
  return std::sqrt(best + plane * plane);
}

Status finalizeSurface(Surface& s, bool set_frame)
{
  if (s.rings.empty())
    return Error(ErrorCode::kInvalidInput, "polygon has no vertices");
  for (size_t r = 0; r < s.rings.size(); ++r)
    if (s.rings[r].size() < 3)
      return Error(ErrorCode::kInvalidInput, (r == 0 ? std::string("polygon") : "hole " + std::to_string(r - 1)) +
                                                 " has " + std::to_string(s.rings[r].size()) +
                                                 " vertices, at least 3 are needed");
  // Newell's normal of the outline.
  const auto& outline = s.rings[0];
  Eigen::Vector3d newell = Eigen::Vector3d::Zero();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (size_t i = 0, j = outline.size() - 1; i < outline.size(); j = i++)
  {
    newell += outline[j].cross(outline[i]);
    centroid += outline[i];
  }
  centroid /= static_cast<double>(outline.size());
  if (!(0.5 * newell.norm() > 1e-8))
    return Error(ErrorCode::kInvalidInput, "polygon has zero area (its vertices are collinear or repeated)");
  Eigen::Vector3d normal = newell.normalized();
  if (set_frame)
  {
    const Eigen::Vector3d n = s.axis_u.cross(s.axis_v);
    if (!(n.norm() > 0.999 && n.norm() < 1.001 && std::abs(n.dot(normal)) > 0.999))
      return Error(ErrorCode::kInvalidInput, "internal error: the texture frame is not in the polygon's plane");
    normal = n.normalized();
  }
  else
  {
    s.origin = outline[0];
    s.axis_u = Eigen::Vector3d::Zero();
    for (size_t i = 1; i < outline.size() && s.axis_u.norm() < 1e-9; ++i)
      s.axis_u = outline[i] - outline[0];
    s.axis_u = (s.axis_u - s.axis_u.dot(normal) * normal).normalized();
    s.axis_v = normal.cross(s.axis_u);
  }
  s.normal = normal;
  s.offset = normal.dot(centroid);
  for (size_t r = 0; r < s.rings.size(); ++r)
    for (size_t i = 0; i < s.rings[r].size(); ++i)
    {
      const double off = std::abs(normal.dot(s.rings[r][i]) - s.offset);
      if (off > kPlanarityToleranceM)
        return Error(ErrorCode::kInvalidInput, "polygon is not planar: vertex " + std::to_string(i) +
                                                   (r ? " of hole " + std::to_string(r - 1) : std::string()) + " is " +
                                                   fmt(1000.0 * off) + " mm off the plane of the outline");
    }
  s.rings_uv.clear();
  for (const auto& ring : s.rings)
  {
    std::vector<Eigen::Vector2d> uv;
    for (const auto& p : ring)
      uv.push_back(s.toSurface(p));
    s.rings_uv.push_back(uv);
  }
  return Success{};
}

Expected<World> parseWorldEntries(const std::string& yaml_text, const std::string& source)
{
  const auto root = yaml_util::parseYaml(yaml_text, source);
  if (!root)
    return root.error();
  const MapReader m(root->root(), source);
  TRY(m.check({"name", "description", "lighting", "appearance", "surfaces", "route", "xtion", "fixed_cameras"}));
  World world;
  world.source = source;
  world.name = std::filesystem::path(source).stem().string();
  if (m.has("name"))
    TRY_ASSIGN(world.name, m.text("name"));
  TRY_ASSIGN(world.lighting, parseLighting(m["lighting"], source + ": lighting"));
  TRY_ASSIGN(world.appearance, parseAppearance(m["appearance"], source + ": appearance"));

  TRY(m.require("surfaces"));
  if (!m["surfaces"].IsSequence() || m["surfaces"].size() == 0)
    return parseError(source + ": surfaces", "expected a non-empty list");
  std::set<std::string> names;
  for (size_t i = 0; i < m["surfaces"].size(); ++i)
  {
    std::vector<Surface> surfaces;
    TRY_ASSIGN(surfaces, parseSurface(m["surfaces"][i], i, source));
    for (auto& s : surfaces)
    {
      if (!names.insert(s.name).second)
        return invalid(source + ": surfaces[" + std::to_string(i) + "]", "the name '" + s.name + "' is used twice");
      world.surfaces.push_back(std::move(s));
    }
  }
  TRY(m.require("route"));
  TRY_ASSIGN(world.route, parseRoute(m["route"], source + ": route"));
  TRY_ASSIGN(world.xtion, parseXtion(m["xtion"], source + ": xtion"));

  TRY(m.require("fixed_cameras"));
  if (!m["fixed_cameras"].IsSequence())
    return parseError(source + ": fixed_cameras", "expected a list");
  std::set<std::string> camera_names;
  for (size_t i = 0; i < m["fixed_cameras"].size(); ++i)
  {
    SimulatedFixedCamera c;
    TRY_ASSIGN(c, parseFixedCamera(m["fixed_cameras"][i], i, source, world.appearance.fixed_cameras));
    if (!camera_names.insert(c.name).second)
      return invalid(source + ": fixed_cameras[" + std::to_string(i) + "]",
                     "the camera name '" + c.name + "' is used twice");
    world.fixed_cameras.push_back(std::move(c));
  }
  return world;
}

Expected<World> loadWorldFile(const std::string& path)
{
  const auto text = readFile(path);
  if (!text)
    return text.error();
  return parseWorld(*text, std::filesystem::path(path).filename().string());
}

}  // namespace simulation
}  // namespace insitu_calibration
