#include "insitu_calibration/simulation/true_edges.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "insitu_calibration/io/atomic_file.h"
#include "io/yaml_util.h"

namespace insitu_calibration
{
namespace simulation
{
namespace
{
using Interval = std::pair<double, double>;

// Parameters t in [t0, t1] of the line p(t) = origin + t dir (in a surface's uv frame) inside the polygon.
std::vector<Interval> clipToPolygon(const Surface& s, const Eigen::Vector2d& origin, const Eigen::Vector2d& dir,
                                    double t0, double t1)
{
  std::vector<double> ts;
  const Eigen::Vector2d normal(-dir.y(), dir.x());
  for (const auto& ring : s.rings_uv)
    for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++)
    {
      const double da = normal.dot(ring[j] - origin);
      const double db = normal.dot(ring[i] - origin);
      if ((da > 0) == (db > 0) || da == db)
        continue;
      const Eigen::Vector2d x = ring[j] + (ring[i] - ring[j]) * (da / (da - db));
      ts.push_back(dir.dot(x - origin));
    }
  std::sort(ts.begin(), ts.end());
  std::vector<Interval> out;
  for (size_t k = 0; k + 1 < ts.size(); k += 2)
  {
    const double a = std::max(ts[k], t0), b = std::min(ts[k + 1], t1);
    if (b - a > 1e-6)
      out.push_back({a, b});
  }
  return out;
}

std::vector<Interval> subtract(const std::vector<Interval>& in, double a, double b)
{
  std::vector<Interval> out;
  for (const auto& [x, y] : in)
  {
    if (b <= x || a >= y)
    {
      out.push_back({x, y});
      continue;
    }
    if (a > x)
      out.push_back({x, a});
    if (b < y)
      out.push_back({b, y});
  }
  return out;
}

struct Candidate
{
  bool along_v;  // the line is u = c, running along v
  double c;
  double t0, t1;
  int above;  // rectangles with index >= above can cover it
};

// A material's joints: both sides of every joint along u (lines v = c), and of the joints across u - a grid for
// tiles, per row for planks and bricks (whose rows are shifted), unless there are more than kMaxJointSegments.
template <typename GridLines>
void materialJoints(const Texture& tex, const Eigen::Vector4d& bounds, GridLines& gridLines,
                    std::vector<Candidate>& candidates)
{
  constexpr double kMaxJointSegments = 20000.0;
  gridLines(false, tex.offset.y(), tex.cell.y(), 0.0);
  gridLines(false, tex.offset.y(), tex.cell.y(), tex.joint);
  if (tex.pattern == Texture::Pattern::kTiles)
  {
    gridLines(true, tex.offset.x(), tex.cell.x(), 0.0);
    gridLines(true, tex.offset.x(), tex.cell.x(), tex.joint);
    return;
  }
  const double rows = (bounds[3] - bounds[1]) / tex.cell.y() + 1.0,
               columns = (bounds[2] - bounds[0]) / tex.cell.x() + 2.0;
  if (!(rows * columns <= kMaxJointSegments))
    return;
  for (long row = static_cast<long>(std::floor((bounds[1] - tex.offset.y()) / tex.cell.y()));
       tex.offset.y() + row * tex.cell.y() <= bounds[3]; ++row)
  {
    const double v0 = tex.offset.y() + row * tex.cell.y();
    const double u0 = tex.offset.x() + tex.rowShift(row);
    for (long k = static_cast<long>(std::floor((bounds[0] - u0) / tex.cell.x())); u0 + k * tex.cell.x() <= bounds[2];
         ++k)
      for (const double side : {0.0, tex.joint})
        candidates.push_back({true, u0 + k * tex.cell.x() + side, v0 + tex.joint, v0 + tex.cell.y(), 0});
  }
}

void textureEdges(const Surface& s, std::vector<TrueEdge>& out)
{
  const Texture& tex = s.texture;
  Eigen::Vector4d bounds(1e300, 1e300, -1e300, -1e300);
  for (const auto& ring : s.rings_uv)
    for (const auto& p : ring)
      bounds = Eigen::Vector4d(std::min(bounds[0], p.x()), std::min(bounds[1], p.y()), std::max(bounds[2], p.x()),
                               std::max(bounds[3], p.y()));
  std::vector<Candidate> candidates;
  auto gridLines = [&](bool along_v, double offset, double period, double shift) {
    const double lo = along_v ? bounds[0] : bounds[1];
    const double hi = along_v ? bounds[2] : bounds[3];
    for (double k = std::ceil((lo - offset - shift) / period); offset + shift + k * period <= hi; k += 1.0)
      candidates.push_back(
          {along_v, offset + shift + k * period, along_v ? bounds[1] : bounds[0], along_v ? bounds[3] : bounds[2], 0});
  };
  if (tex.pattern == Texture::Pattern::kChecker)
  {
    gridLines(true, tex.offset.x(), tex.cell.x(), 0.0);
    gridLines(false, tex.offset.y(), tex.cell.y(), 0.0);
  }
  else if (tex.pattern == Texture::Pattern::kStripes)
  {
    const double period = tex.cell.x() + tex.cell.y();
    const bool along_v = !tex.stripes_along_v;  // bands across u are separated by lines u = c
    const double offset = along_v ? tex.offset.x() : tex.offset.y();
    gridLines(along_v, offset, period, 0.0);
    gridLines(along_v, offset, period, tex.cell.x());
  }
  else if (tex.material())
    materialJoints(tex, bounds, gridLines, candidates);
  for (size_t r = 0; r < tex.rects.size(); ++r)
  {
    const TextureRect& rect = tex.rects[r];
    const int above = static_cast<int>(r) + 1;
    candidates.push_back({true, rect.min.x(), rect.min.y(), rect.max.y(), above});
    candidates.push_back({true, rect.max.x(), rect.min.y(), rect.max.y(), above});
    candidates.push_back({false, rect.min.y(), rect.min.x(), rect.max.x(), above});
    candidates.push_back({false, rect.max.y(), rect.min.x(), rect.max.x(), above});
  }
  for (const Candidate& c : candidates)
  {
    const Eigen::Vector2d origin = c.along_v ? Eigen::Vector2d(c.c, 0.0) : Eigen::Vector2d(0.0, c.c);
    const Eigen::Vector2d dir = c.along_v ? Eigen::Vector2d(0.0, 1.0) : Eigen::Vector2d(1.0, 0.0);
    std::vector<Interval> parts = clipToPolygon(s, origin, dir, c.t0, c.t1);
    for (size_t r = static_cast<size_t>(c.above); r < tex.rects.size(); ++r)
    {
      const TextureRect& rect = tex.rects[r];
      const double across_lo = c.along_v ? rect.min.x() : rect.min.y();
      const double across_hi = c.along_v ? rect.max.x() : rect.max.y();
      if (c.c > across_lo && c.c < across_hi)
        parts = subtract(parts, c.along_v ? rect.min.y() : rect.min.x(), c.along_v ? rect.max.y() : rect.max.x());
    }
    const Eigen::Vector2d across(dir.y(), dir.x());
    for (const auto& [a, b] : parts)
    {
      if (b - a < 1e-3)
        continue;
      // Keep the part only where the colours on its two sides differ, and both sides are on the surface (a line on
      // the polygon's own outline is an outline edge already).
      const Eigen::Vector2d mid = origin + dir * (0.5 * (a + b));
      const Eigen::Vector2d p1 = mid - 1e-3 * across, p2 = mid + 1e-3 * across;
      if (!s.contains(p1) || !s.contains(p2))
        continue;
      int r1 = 0, r2 = 0;
      if ((tex.sample(p1.x(), p1.y(), &r1) - tex.sample(p2.x(), p2.y(), &r2)).norm() < 1.0)
        continue;
      out.push_back({s.toWorld(origin + a * dir), s.toWorld(origin + b * dir), "texture", {s.name}});
    }
  }
}

bool coplanar(const Surface& a, const Surface& b)
{
  return std::abs(a.normal.dot(b.normal)) > 1.0 - 1e-9 && std::abs(a.normal.dot(b.origin) - a.offset) < 1e-6;
}
}  // namespace

std::vector<TrueEdge> computeTrueEdges(const World& world)
{
  // Polygon edges, merged when identical (to 0.1 mm) between surfaces.
  using Key = std::tuple<long, long, long, long, long, long>;
  auto quantise = [](const Eigen::Vector3d& p) {
    return std::make_tuple(std::lround(p.x() * 1e4), std::lround(p.y() * 1e4), std::lround(p.z() * 1e4));
  };
  std::map<Key, size_t> index;
  std::vector<TrueEdge> edges;
  std::vector<std::vector<size_t>> owners;
  for (size_t si = 0; si < world.surfaces.size(); ++si)
  {
    const Surface& s = world.surfaces[si];
    for (const auto& ring : s.rings)
      for (size_t i = 0; i < ring.size(); ++i)
      {
        const Eigen::Vector3d& a = ring[i];
        const Eigen::Vector3d& b = ring[(i + 1) % ring.size()];
        if ((a - b).norm() < 1e-3)
          continue;
        auto ka = quantise(a), kb = quantise(b);
        if (kb < ka)
          std::swap(ka, kb);
        const Key key = std::tuple_cat(ka, kb);
        const auto it = index.find(key);
        if (it == index.end())
        {
          index[key] = edges.size();
          edges.push_back({a, b, "", {s.name}});
          owners.push_back({si});
        }
        else if (std::find(owners[it->second].begin(), owners[it->second].end(), si) == owners[it->second].end())
        {
          edges[it->second].surfaces.push_back(s.name);
          owners[it->second].push_back(si);
        }
      }
  }
  for (size_t e = 0; e < edges.size(); ++e)
  {
    const auto& o = owners[e];
    if (o.size() == 1)
    {
      edges[e].kind = "outline";
      continue;
    }
    bool all_coplanar = true;
    for (size_t i = 1; i < o.size(); ++i)
      all_coplanar &= coplanar(world.surfaces[o[0]], world.surfaces[o[i]]);
    edges[e].kind = all_coplanar ? "seam" : "crease";
  }
  for (const Surface& s : world.surfaces)
    textureEdges(s, edges);
  return edges;
}

std::string formatTrueEdges(const std::vector<TrueEdge>& edges, const std::string& world_name)
{
  YAML::Emitter out;
  out.SetDoublePrecision(9);
  out << YAML::BeginMap;
  out << YAML::Key << "world" << YAML::Value << world_name;
  out << YAML::Key << "frame_id" << YAML::Value << "map";
  out << YAML::Key << "edges" << YAML::Value << YAML::BeginSeq;
  for (const TrueEdge& e : edges)
  {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "start" << YAML::Value;
    yaml_util::emitVector(out, e.start);
    out << YAML::Key << "end" << YAML::Value;
    yaml_util::emitVector(out, e.end);
    out << YAML::Key << "kind" << YAML::Value << e.kind;
    out << YAML::Key << "surfaces" << YAML::Value << YAML::Flow << e.surfaces;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

Status saveTrueEdges(const std::string& path, const std::vector<TrueEdge>& edges, const std::string& world_name)
{
  return writeFileAtomically(path, formatTrueEdges(edges, world_name));
}

Expected<std::vector<TrueEdge>> loadTrueEdges(const std::string& path)
{
  const auto text = readFile(path);
  if (!text)
    return text.error();
  const auto root = yaml_util::parseYaml(*text, path);
  if (!root)
    return root.error();
  const yaml_util::YamlNode list = yaml_util::child(root->root(), "edges");
  if (!list || !list.IsSequence())
    return Error(ErrorCode::kParseError, path + ": missing key 'edges' (a list)");
  std::vector<TrueEdge> edges;
  for (size_t i = 0; i < list.size(); ++i)
  {
    const std::string where = path + ": edges[" + std::to_string(i) + "]";
    TrueEdge e;
    const auto a = yaml_util::toVector<3>(list[i]["start"], where + ".start");
    const auto b = yaml_util::toVector<3>(list[i]["end"], where + ".end");
    if (!a || !b)
      return !a ? a.error() : b.error();
    e.start = *a;
    e.end = *b;
    if (!list[i]["kind"] || !list[i]["kind"].IsScalar())
      return Error(ErrorCode::kParseError, where + ": missing key 'kind'");
    e.kind = list[i]["kind"].as<std::string>();
    if (list[i]["surfaces"] && list[i]["surfaces"].IsSequence())
      for (const auto& n : list[i]["surfaces"])
        e.surfaces.push_back(n.as<std::string>());
    edges.push_back(e);
  }
  return edges;
}

}  // namespace simulation
}  // namespace insitu_calibration
