#include "generator_layouts.h"

#include <cmath>
#include <cstdio>

namespace insitu_calibration
{
namespace simulation
{
namespace generator
{
namespace
{
using V2 = Eigen::Vector2d;
using V3 = Eigen::Vector3d;

const std::vector<Color> kPaint = {{214, 206, 186}, {206, 196, 174}, {178, 196, 214}, {200, 204, 196},
                                   {226, 222, 210}, {190, 170, 150}, {160, 182, 160}, {236, 230, 218}};
const std::vector<Color> kWood = {{150, 108, 70}, {120, 84, 54}, {176, 136, 92}, {96, 70, 50}, {196, 160, 116}};
const std::vector<Color> kFabric = {{42, 72, 146},   {178, 48, 44}, {64, 130, 92},   {30, 30, 34},
                                    {120, 140, 150}, {140, 50, 60}, {200, 170, 110}, {80, 80, 96}};
const std::vector<Color> kMetal = {{196, 200, 206}, {90, 94, 100}, {236, 232, 222}, {60, 60, 64}, {160, 164, 170}};
const std::vector<Color> kAccent = {{196, 60, 46}, {40, 40, 48},    {236, 196, 60},  {46, 120, 74},
                                    {28, 52, 92},  {246, 246, 240}, {150, 200, 236}, {250, 230, 120}};

Texture solid(const Color& c)
{
  Texture t;
  t.color = c;
  return t;
}

Texture pattern(Texture::Pattern p, const Color& a, const Color& b, const V2& cell, bool horizontal = false)
{
  Texture t;
  t.pattern = p;
  t.color = a;
  t.color2 = b;
  t.cell = cell;
  t.stripes_along_v = horizontal;
  return t;
}

Color darker(const Color& c, float f)
{
  return (c * f).array().round().matrix();
}

// Floors: tiles (checker), wooden planks (wide bands with a thin dark joint), or carpet tiles.
Texture floorTexture(Rng& rng)
{
  const int kind = rng.integer(0, 2);
  if (kind == 0)
  {
    const Color c = rng.color({{168, 160, 146}, {200, 200, 196}, {150, 150, 160}});
    const double cell = rng.uniform(0.3, 0.6);
    return pattern(Texture::Pattern::kChecker, c, darker(c, rng.uniform(0.7, 0.88)), V2(cell, cell));
  }
  if (kind == 1)
  {
    const Color c = rng.color(kWood);
    return pattern(Texture::Pattern::kStripes, c, darker(c, 0.6f), V2(rng.uniform(0.12, 0.22), 0.006));
  }
  const Color c = rng.color({{90, 90, 110}, {110, 70, 60}, {96, 110, 96}, {130, 120, 110}});
  const double cell = rng.uniform(0.5, 0.6);
  return pattern(Texture::Pattern::kChecker, c, darker(c, 0.9f), V2(cell, cell));
}

Texture ceilingTexture(Rng& rng)
{
  const Color c = rng.color({{232, 232, 226}, {240, 240, 236}}, 6);
  if (rng.chance(0.3))
    return solid(c);
  const double cell = rng.chance(0.5) ? 0.6 : 1.2;
  return pattern(Texture::Pattern::kChecker, c, darker(c, 0.9f), V2(cell, 0.6));
}

// ---- Furniture: parts in the item's frame (centred, front towards -y), placed by quarter turns ---------------
struct Part
{
  std::string name;
  Box3 box;
  Texture texture;
  double yaw_deg = 0.0;
};
struct Item
{
  std::string name;
  std::vector<Part> parts;
  V2 half;  // half footprint in the item's frame
};

Box3 B(double x0, double y0, double z0, double x1, double y1, double z1)
{
  return {V3(x0, y0, z0), V3(x1, y1, z1)};
}

V2 turn(const V2& p, int q)
{
  switch (((q % 4) + 4) % 4)
  {
    case 1:
      return {-p.y(), p.x()};
    case 2:
      return {-p.x(), -p.y()};
    case 3:
      return {p.y(), -p.x()};
    default:
      return p;
  }
}

Eigen::AlignedBox2d footprint(const Item& item, const V2& center, int q)
{
  const V2 h = turn(item.half, q).cwiseAbs();
  return {center - h, center + h};
}

void put(Scene& scene, const Item& item, const V2& center, int q)
{
  for (const Part& p : item.parts)
  {
    const V2 a = center + turn(p.box.min.head<2>(), q), b = center + turn(p.box.max.head<2>(), q);
    scene.box(item.name + (p.name.empty() ? "" : "_" + p.name),
              {V3(std::min(a.x(), b.x()), std::min(a.y(), b.y()), p.box.min.z()),
               V3(std::max(a.x(), b.x()), std::max(a.y(), b.y()), p.box.max.z())},
              p.texture, true, p.yaw_deg);
  }
}

Item chair(Rng& rng, const Color& c)
{
  return {"chair",
          {{"seat", B(-0.23, -0.22, 0, 0.23, 0.2, 0.46), solid(c)},
           {"back", B(-0.23, 0.2, 0, 0.23, 0.27, 0.9 + rng.uniform(-0.05, 0.1)), solid(darker(c, 0.8f))}},
          V2(0.23, 0.27)};
}

Item table(Rng& rng, double w, double d, double h)
{
  const Color top = rng.color(kWood), base = rng.color(kMetal);
  return {"table",
          {{"base", B(-w / 2 + 0.1, -d / 2 + 0.1, 0, w / 2 - 0.1, d / 2 - 0.1, h - 0.04), solid(base)},
           {"top", B(-w / 2, -d / 2, h - 0.04, w / 2, d / 2, h), solid(top)}},
          V2(w / 2, d / 2)};
}

Item sofa(Rng& rng)
{
  const double w = rng.uniform(1.4, 2.2);
  const Color c = rng.color(kFabric);
  return {"sofa",
          {{"base", B(-w / 2 + 0.15, -0.42, 0, w / 2 - 0.15, 0.22, 0.42), solid(c)},
           {"back", B(-w / 2, 0.22, 0, w / 2, 0.42, 0.85), solid(darker(c, 0.85f))},
           {"arm_l", B(-w / 2, -0.42, 0, -w / 2 + 0.15, 0.22, 0.62), solid(darker(c, 0.9f))},
           {"arm_r", B(w / 2 - 0.15, -0.42, 0, w / 2, 0.22, 0.62), solid(darker(c, 0.9f))}},
          V2(w / 2, 0.42)};
}

Item shelf(Rng& rng)
{
  const double w = rng.uniform(0.8, 1.8), h = rng.uniform(1.2, 2.1);
  const Color c = rng.color(kWood);
  Texture t = pattern(Texture::Pattern::kStripes, c, darker(c, 0.45f), V2(rng.uniform(0.3, 0.4), 0.03), true);
  return {"shelf", {{"", B(-w / 2, -0.2, 0, w / 2, 0.2, h), t}}, V2(w / 2, 0.2)};
}

Item cabinet(Rng& rng)
{
  const double w = rng.uniform(0.8, 1.6), h = rng.uniform(0.7, 1.4);
  const Color c = rng.color(kMetal);
  Texture t = pattern(Texture::Pattern::kStripes, c, darker(c, 0.5f), V2(rng.uniform(0.3, 0.4), 0.015), true);
  return {"cabinet", {{"", B(-w / 2, -0.24, 0, w / 2, 0.24, h), t}}, V2(w / 2, 0.24)};
}

Item plant(Rng& rng)
{
  const Color pot = rng.color({{176, 92, 56}, {200, 200, 196}, {60, 60, 64}});
  const Color leaf = rng.color({{52, 120, 48}, {70, 110, 60}});
  return {"plant",
          {{"pot", B(-0.2, -0.2, 0, 0.2, 0.2, 0.45), solid(pot)},
           {"leaves", B(-0.24, -0.24, 0.45, 0.24, 0.24, rng.uniform(1.0, 1.6)),
            pattern(Texture::Pattern::kChecker, leaf, darker(leaf, 0.7f), V2(0.14, 0.14)), rng.uniform(5, 40)}},
          V2(0.34, 0.34)};
}

Item desk(Rng& rng, double w, double d)
{
  const Color top = rng.color(kWood), side = rng.color(kMetal);
  return {"desk",
          {{"top", B(-w / 2, -d / 2, 0.72, w / 2, d / 2, 0.75), solid(top)},
           {"side_l", B(-w / 2, -d / 2 + 0.05, 0, -w / 2 + 0.03, d / 2 - 0.02, 0.72), solid(side)},
           {"side_r", B(w / 2 - 0.03, -d / 2 + 0.05, 0, w / 2, d / 2 - 0.02, 0.72), solid(side)},
           {"panel", B(-w / 2 + 0.03, d / 2 - 0.05, 0.3, w / 2 - 0.03, d / 2 - 0.02, 0.72), solid(side)},
           {"monitor", B(-0.28, d / 2 - 0.2, 0.75, 0.28, d / 2 - 0.17, 1.1), solid(Color(24, 24, 28))}},
          V2(w / 2, d / 2)};
}

Item bench(Rng& rng)
{
  const double w = rng.uniform(1.2, 2.0);
  const Color c = rng.color(kWood);
  return {"bench",
          {{"seat", B(-w / 2, -0.2, 0.4, w / 2, 0.2, 0.45), solid(c)},
           {"leg_l", B(-w / 2 + 0.05, -0.18, 0, -w / 2 + 0.1, 0.18, 0.4), solid(Color(60, 60, 64))},
           {"leg_r", B(w / 2 - 0.1, -0.18, 0, w / 2 - 0.05, 0.18, 0.4), solid(Color(60, 60, 64))}},
          V2(w / 2, 0.2)};
}

Item counter(Rng& rng, double w)
{
  const Color front = rng.color(kPaint), top = rng.color(kWood);
  Texture t = solid(front);
  t.rects.push_back({V2(0, 0), V2(w, 0.1), darker(front, 0.6f)});
  return {"reception",
          {{"front", B(-w / 2, -0.35, 0, w / 2, 0.35, 1.05), t},
           {"top", B(-w / 2 - 0.05, -0.4, 1.05, w / 2 + 0.05, 0.4, 1.1), solid(top)}},
          V2(w / 2 + 0.05, 0.4)};
}

// ---- Placement ------------------------------------------------------------------------------------------------
struct Placer
{
  Scene& scene;
  Rng& rng;
  Eigen::AlignedBox2d room;
  std::vector<Eigen::AlignedBox2d> taken;  // placed footprints and keep-out zones (doorways)

  bool fits(const Eigen::AlignedBox2d& f, double margin) const
  {
    if (!room.contains(f))
      return false;
    for (const auto& t : taken)
    {
      Eigen::AlignedBox2d grown(t.min() - V2::Constant(margin), t.max() + V2::Constant(margin));
      if (grown.intersects(f))
        return false;
    }
    return true;
  }
  bool at(const Item& item, const V2& center, int q, double margin)
  {
    const auto f = footprint(item, center, q);
    if (!fits(f, margin))
      return false;
    put(scene, item, center, q);
    taken.push_back(f);
    return true;
  }
  // Back against a wall side, anywhere along it.
  bool againstWall(const Item& item, const WallSide& side)
  {
    const V2 m = -side.inward;
    const int q = static_cast<int>(std::lround(std::atan2(-m.x(), m.y()) / (M_PI / 2)));
    for (int attempt = 0; attempt < 20; ++attempt)
    {
      const double u = rng.uniform(0.2 + item.half.x(), side.length() - 0.2 - item.half.x());
      if (at(item, side.at(u) + side.inward * (item.half.y() + 0.03), q, 0.15))
        return true;
    }
    return false;
  }
  // Anywhere in a region, turned by a random quarter, at least `margin` from everything else.
  bool inRegion(const Item& item, const Eigen::AlignedBox2d& region, double margin)
  {
    for (int attempt = 0; attempt < 30; ++attempt)
    {
      const V2 c(rng.uniform(region.min().x(), region.max().x()), rng.uniform(region.min().y(), region.max().y()));
      if (at(item, c, rng.integer(0, 3), margin))
        return true;
    }
    return false;
  }
};

// ---- Walls, doorways and what hangs on walls -----------------------------------------------------------------
Texture wallTexture(Rng& rng, const WallSide& side, const std::vector<Opening>& openings, const Color& paint)
{
  Texture t = solid(paint);
  const Color trim = rng.color({{92, 74, 60}, {80, 70, 64}, {236, 236, 232}, {60, 60, 64}});
  t.rects.push_back({V2(0, 0), V2(side.length(), 0.1), trim});
  if (side.height < 3.4 && rng.chance(0.35))
    t.rects.push_back({V2(0, 0.95), V2(side.length(), 1.0), darker(paint, 0.75f)});
  for (const Opening& o : openings)
    t.rects.push_back({V2(o.offset - 0.07, o.sill > 0 ? o.sill - 0.07 : 0),
                       V2(o.offset + o.width + 0.07, o.sill + o.height + 0.07), trim});
  return t;
}

// A small space behind a doorway, so that the opening shows more building.
void vestibule(Scene& scene, Rng& rng, const WallSide& side, const Opening& door)
{
  const V2 out = -side.inward;
  const double depth = rng.uniform(1.2, 2.0);
  const V2 p0 = side.at(door.offset - 0.4), p1 = side.at(door.offset + door.width + 0.4);
  const V2 q0 = p0 + depth * out, q1 = p1 + depth * out;
  const double h = side.height;
  auto v3 = [](const V2& p, double z) { return V3(p.x(), p.y(), z); };
  scene.polygon("vestibule_floor", {v3(p0, 0), v3(p1, 0), v3(q1, 0), v3(q0, 0)}, floorTexture(rng));
  scene.polygon("vestibule_ceiling", {v3(p0, h), v3(p1, h), v3(q1, h), v3(q0, h)}, solid(Color(230, 230, 226)));
  const Color paint = rng.color(kPaint);
  Texture back = solid(paint);
  const double w = (q1 - q0).norm();
  back.rects.push_back({V2(0, 0), V2(w, 0.1), darker(paint, 0.5f)});
  back.rects.push_back({V2(0.5 * w - 0.5, 0), V2(0.5 * w + 0.5, 2.1), rng.color(kWood)});
  scene.wall("vestibule_side", p0, q0, h, {}, solid(paint));
  scene.wall("vestibule_side", q1, p1, h, {}, solid(paint));
  scene.wall("vestibule_back", q0, q1, h, {}, back);
}

// Posters, boards, windows, a TV: rectangles with rectangles on them.
void decorate(Scene& scene, Rng& rng, WallSide& side, bool windows)
{
  const int count = static_cast<int>(side.length() / rng.uniform(2.0, 3.5));
  for (int k = 0; k < count; ++k)
  {
    const bool window = windows && rng.chance(0.4);
    const double w = window ? rng.uniform(1.0, 2.0) : rng.uniform(0.5, 1.4);
    const double h = window ? rng.uniform(0.9, 1.5) : rng.uniform(0.4, 1.1);
    const double v = window ? std::min(side.height - 0.3 - h / 2, rng.uniform(1.4, 1.8)) : rng.uniform(1.3, 1.8);
    const double u = side.reserve(rng, w);
    if (u < 0.0)
      continue;
    Texture t = solid(window ? rng.color(kMetal) : rng.color(kAccent));
    if (window)
      for (int pane = 0, panes = rng.integer(1, 3); pane < panes; ++pane)
        t.rects.push_back({V2(0.06 + pane * (w - 0.06) / panes, 0.06), V2((pane + 1) * (w - 0.06) / panes, h - 0.06),
                           rng.color({{176, 206, 236}, {160, 190, 220}})});
    else
      for (int r = 0, n = rng.integer(1, 4); r < n; ++r)
      {
        const V2 a(rng.uniform(0.04, 0.6 * w), rng.uniform(0.04, 0.6 * h));
        const V2 b(rng.uniform(a.x() + 0.08, w - 0.04), rng.uniform(a.y() + 0.05, h - 0.04));
        if (b.x() > a.x() + 0.05 && b.y() > a.y() + 0.03)
          t.rects.push_back({a, b, rng.color(kAccent)});
      }
    scene.onWall(window ? "window" : "poster", side, u + w / 2, v, V2(w, h), t);
  }
}

void ceilingLights(Scene& scene, Rng& rng, const Eigen::AlignedBox2d& area, double h)
{
  const double step = rng.uniform(2.2, 3.5);
  const V2 size(rng.uniform(0.6, 1.2), rng.uniform(0.2, 0.6));
  for (double x = area.min().x() + step / 2; x < area.max().x() - 0.5; x += step)
    for (double y = area.min().y() + step / 2; y < area.max().y() - 0.5; y += step)
      scene.rectangle("light", V3(x, y, h - 0.002), V3(0, 0, -1), size, solid(Color(252, 250, 236)));
}

// The four walls of a W x D room (origin at a corner), `doors` doorways with vestibules, windows on some walls.
std::vector<WallSide> roomShell(Scene& scene, Rng& rng, double W, double D, double H, int doors, double door_width,
                                double door_height)
{
  scene.polygon("floor", {V3(0, 0, 0), V3(W, 0, 0), V3(W, D, 0), V3(0, D, 0)}, floorTexture(rng));
  scene.polygon("ceiling", {V3(0, 0, H), V3(W, 0, H), V3(W, D, H), V3(0, D, H)}, ceilingTexture(rng));
  std::vector<WallSide> sides = {{"wall_south", V2(0, 0), V2(W, 0), V2(0, 1), H, {}},
                                 {"wall_east", V2(W, 0), V2(W, D), V2(-1, 0), H, {}},
                                 {"wall_north", V2(W, D), V2(0, D), V2(0, -1), H, {}},
                                 {"wall_west", V2(0, D), V2(0, 0), V2(1, 0), H, {}}};
  std::vector<std::vector<Opening>> openings(4);
  for (int d = 0; d < doors; ++d)
  {
    WallSide& side = sides[rng.integer(0, 3)];
    const double u = side.reserve(rng, door_width);
    if (u >= 0.0)
      openings[&side - sides.data()].push_back({u, door_width, door_height, 0.0});
  }
  const Color paint = rng.color(kPaint);
  for (size_t k = 0; k < 4; ++k)
  {
    const Color c = rng.chance(0.3) ? rng.color(kPaint) : paint;
    scene.wall(sides[k].name, sides[k].a, sides[k].b, H, openings[k], wallTexture(rng, sides[k], openings[k], c));
    for (const Opening& o : openings[k])
      vestibule(scene, rng, sides[k], o);
  }
  return sides;
}

std::vector<Eigen::AlignedBox2d> doorKeepOut(const std::vector<WallSide>& sides)
{
  std::vector<Eigen::AlignedBox2d> out;
  for (const auto& side : sides)
    for (const auto& [a, b] : side.used)
    {
      Eigen::AlignedBox2d box(side.at(a));
      box.extend(side.at(b) + 1.2 * side.inward);
      out.push_back(box);
    }
  return out;
}

std::vector<V2> cornerAndWallSites(const Eigen::AlignedBox2d& r)
{
  const V2 lo = r.min() + V2::Constant(0.25), hi = r.max() - V2::Constant(0.25), c = r.center();
  return {lo,
          V2(hi.x(), lo.y()),
          hi,
          V2(lo.x(), hi.y()),
          V2(c.x(), lo.y()),
          V2(hi.x(), c.y()),
          V2(c.x(), hi.y()),
          V2(lo.x(), c.y())};
}
}  // namespace

namespace
{
// Along-wall furniture and a few free-standing pieces, about one item per `area_per_item` square metres.
void furnish(Placer& placer, std::vector<WallSide>& sides, double area_per_item, bool seating)
{
  Rng& rng = placer.rng;
  const int items = std::max(2, static_cast<int>(placer.room.volume() / area_per_item));
  for (int k = 0; k < items; ++k)
  {
    WallSide& side = sides[rng.integer(0, static_cast<int>(sides.size()) - 1)];
    const int what = rng.integer(0, seating ? 5 : 3);
    const Item item = what == 0   ? shelf(rng)
                      : what == 1 ? cabinet(rng)
                      : what == 2 ? plant(rng)
                      : what == 3 ? bench(rng)
                      : what == 4 ? sofa(rng)
                                  : chair(rng, rng.color(kFabric));
    if (rng.chance(0.75))
      placer.againstWall(item, side);
    else
      placer.inRegion(item, placer.room, 1.0);
  }
}

Layout buildRoom(Rng& rng)
{
  Layout layout;
  Scene& scene = layout.scene;
  const double W = rng.uniform(4.0, 10.0), D = rng.uniform(4.0, std::min(8.0, W)), H = rng.uniform(2.6, 3.2);
  layout.ceiling_height = H;
  auto sides = roomShell(scene, rng, W, D, H, rng.integer(1, 2), rng.uniform(0.9, 1.2), 2.1);
  scene.plan.walkable = Eigen::AlignedBox2d(V2(0, 0), V2(W, D));
  Placer placer{scene, rng, scene.plan.walkable, doorKeepOut(sides)};
  for (auto& side : sides)
    decorate(scene, rng, side, rng.chance(0.5));
  ceilingLights(scene, rng, scene.plan.walkable, H);
  // A table with chairs around it in the middle of larger rooms.
  if (W * D > 25.0)
  {
    const double tw = rng.uniform(0.8, 1.6), td = rng.uniform(0.6, 1.0);
    const V2 c(rng.uniform(0.35 * W, 0.65 * W), rng.uniform(0.35 * D, 0.65 * D));
    if (placer.at(table(rng, tw, td, rng.uniform(0.42, 0.76)), c, 0, 0.2))
    {
      const Color cc = rng.color(kFabric);
      placer.at(chair(rng, cc), c + V2(0, -td / 2 - 0.35), 2, 0.02);
      placer.at(chair(rng, cc), c + V2(0, td / 2 + 0.35), 0, 0.02);
    }
  }
  furnish(placer, sides, 5.0, true);
  layout.camera_sites = cornerAndWallSites(scene.plan.walkable);
  char text[128];
  std::snprintf(text, sizeof(text), "Room %.1f x %.1f x %.1f m", W, D, H);
  layout.description = text;
  return layout;
}

// A raised stage along the west wall with steps in front.
void stage(Scene& scene, Placer& placer, Rng& rng, double D)
{
  const double depth = rng.uniform(1.8, 2.8), h = rng.uniform(0.45, 0.6),
               width = rng.uniform(4.0, std::min(7.0, D - 2));
  const double y0 = rng.uniform(1.0, D - 1.0 - width);
  const Color c = rng.color(kWood), riser = rng.color(kMetal);
  Texture top = pattern(Texture::Pattern::kStripes, c, darker(c, 0.6f), V2(0.16, 0.006));
  scene.box("stage", {V3(0.0, y0, 0), V3(depth, y0 + width, h)}, solid(riser));
  scene.polygon("stage_top",
                {V3(0.0, y0, h + 0.002), V3(depth, y0, h + 0.002), V3(depth, y0 + width, h + 0.002),
                 V3(0.0, y0 + width, h + 0.002)},
                top);
  const int steps = rng.integer(2, 3);
  for (int s = 1; s < steps + 0; ++s)
    scene.box("step", {V3(depth, y0, 0), V3(depth + 0.3 * (steps - s), y0 + width, h * s / steps)},
              solid(s % 2 ? darker(riser, 0.8f) : riser));
  placer.taken.push_back({V2(0.0, y0), V2(depth + 0.3 * steps, y0 + width)});
}

Layout buildHall(Rng& rng)
{
  Layout layout;
  Scene& scene = layout.scene;
  const double W = rng.uniform(12.0, 20.0), D = rng.uniform(8.0, 12.0), H = rng.uniform(4.0, 6.0);
  layout.ceiling_height = H;
  auto sides = roomShell(scene, rng, W, D, H, rng.integer(2, 3), rng.uniform(1.6, 2.4), rng.uniform(2.4, 2.8));
  scene.plan.walkable = Eigen::AlignedBox2d(V2(0, 0), V2(W, D));
  Placer placer{scene, rng, scene.plan.walkable, doorKeepOut(sides)};
  for (auto& side : sides)
    decorate(scene, rng, side, true);
  ceilingLights(scene, rng, scene.plan.walkable, H);
  if (rng.chance(0.8))
  {
    const int nx = rng.integer(2, 3), ny = rng.integer(1, 2);
    const double size = rng.uniform(0.3, 0.6);
    const Color c = rng.color(kPaint);
    for (int i = 1; i <= nx; ++i)
      for (int j = 1; j <= ny; ++j)
      {
        const V2 p(W * i / (nx + 1.0), D * j / (ny + 1.0));
        Texture t = solid(c);
        t.rects.push_back({V2(0, 0), V2(size, 0.12), darker(c, 0.5f)});
        placer.at({"column", {{"", B(-size / 2, -size / 2, 0, size / 2, size / 2, H), t}}, V2(size / 2, size / 2)}, p,
                  0, 0.0);
      }
  }
  if (rng.chance(0.7))
    stage(scene, placer, rng, D);
  placer.againstWall(counter(rng, rng.uniform(2.0, 4.0)), sides[rng.integer(0, 3)]);
  furnish(placer, sides, 10.0, true);
  layout.camera_sites = cornerAndWallSites(scene.plan.walkable);
  char text[128];
  std::snprintf(text, sizeof(text), "Hall %.1f x %.1f x %.1f m", W, D, H);
  layout.description = text;
  return layout;
}

Layout buildOffice(Rng& rng)
{
  Layout layout;
  Scene& scene = layout.scene;
  const double W = rng.uniform(8.0, 14.0), D = rng.uniform(6.0, 10.0), H = rng.uniform(2.7, 3.2);
  layout.ceiling_height = H;
  auto sides = roomShell(scene, rng, W, D, H, rng.integer(1, 2), rng.uniform(0.9, 1.2), 2.1);
  scene.plan.walkable = Eigen::AlignedBox2d(V2(0, 0), V2(W, D));
  Placer placer{scene, rng, scene.plan.walkable, doorKeepOut(sides)};
  for (auto& side : sides)
    decorate(scene, rng, side, rng.chance(0.6));
  ceilingLights(scene, rng, scene.plan.walkable, H);
  // Desk clusters: two rows of desks back to back with a screen between, chairs in front, aisles between clusters.
  const double dw = rng.uniform(1.2, 1.6), dd = 0.8;
  const int per_row = rng.integer(2, 3);
  const double pitch_y = 2 * dd + 2 * 0.6 + rng.uniform(1.4, 1.8);
  const Color chair_color = rng.color(kFabric), screen = rng.color(kFabric);
  for (double y = 1.8 + dd; y + dd + 1.5 < D; y += pitch_y)
    for (double x = 1.5 + per_row * dw / 2; x + per_row * dw / 2 + 1.5 < W; x += per_row * dw + 1.8)
    {
      const Item s{
          "screen",
          {{"", B(-per_row * dw / 2, -0.03, 0, per_row * dw / 2, 0.03, rng.uniform(1.15, 1.5)), solid(screen)}},
          V2(per_row * dw / 2, 0.03)};
      if (!placer.fits(footprint(s, V2(x, y), 0), 1.0))
        continue;
      placer.at(s, V2(x, y), 0, 0.0);
      for (int i = 0; i < per_row; ++i)
      {
        const double cx = x - per_row * dw / 2 + (i + 0.5) * dw;
        placer.at(desk(rng, dw - 0.02, dd), V2(cx, y - 0.03 - dd / 2), 0, 0.0);
        placer.at(desk(rng, dw - 0.02, dd), V2(cx, y + 0.03 + dd / 2), 2, 0.0);
        placer.at(chair(rng, chair_color), V2(cx, y - 0.03 - dd - 0.3), 2, 0.0);
        placer.at(chair(rng, chair_color), V2(cx, y + 0.03 + dd + 0.3), 0, 0.0);
      }
    }
  furnish(placer, sides, 12.0, false);
  layout.camera_sites = cornerAndWallSites(scene.plan.walkable);
  char text[128];
  std::snprintf(text, sizeof(text), "Office %.1f x %.1f x %.1f m", W, D, H);
  layout.description = text;
  return layout;
}

// Rooms north of the corridor, each with a doorway (and sometimes an internal window) onto it.
void corridorRooms(Scene& scene, Rng& rng, double L, double Wc, double Dr, double H, WallSide& north)
{
  std::vector<double> bounds{0.0};
  while (bounds.back() < L - 3.0)
    bounds.push_back(std::min(L, bounds.back() + rng.uniform(3.0, 5.0)));
  bounds.back() = L;
  std::vector<Opening> openings;
  for (size_t r = 0; r + 1 < bounds.size(); ++r)
  {
    // north runs from x = L to x = 0: u = L - x.
    const double x0 = bounds[r], x1 = bounds[r + 1], w = rng.uniform(0.9, 1.1);
    const double door_x = rng.uniform(x0 + 0.4, x1 - 0.4 - w);
    openings.push_back({L - door_x - w, w, 2.1, 0.0});
    north.used.emplace_back(L - door_x - w, L - door_x);
    if (rng.chance(0.4) && door_x - x0 > 2.0)
    {
      const double ww = rng.uniform(0.8, std::min(1.4, door_x - x0 - 1.0));
      openings.push_back({L - door_x + 0.4, ww, 0.8, 1.1});
      north.used.emplace_back(L - door_x + 0.4, L - door_x + 0.4 + ww);
    }
    if (r > 0)
      scene.wall("room_partition", V2(x0, Wc), V2(x0, Wc + Dr), H, {}, solid(rng.color(kPaint)));
    // A table or a shelf in each room, seen through the doorway.
    Placer room{scene,
                rng,
                Eigen::AlignedBox2d(V2(x0 + 0.1, Wc + 0.1), V2(x1 - 0.1, Wc + Dr - 0.1)),
                {Eigen::AlignedBox2d(V2(door_x, Wc), V2(door_x + w, Wc + 1.0))}};
    room.inRegion(rng.chance(0.5) ? table(rng, 1.2, 0.7, 0.74) : shelf(rng), room.room, 0.2);
    room.inRegion(cabinet(rng), room.room, 0.2);
  }
  scene.wall(north.name, north.a, north.b, H, openings, wallTexture(rng, north, openings, rng.color(kPaint)));
  scene.wall("rooms_back", V2(L, Wc + Dr), V2(0, Wc + Dr), H, {}, solid(rng.color(kPaint)));
}

Layout buildCorridor(Rng& rng)
{
  Layout layout;
  Scene& scene = layout.scene;
  const double L = rng.uniform(15.0, 25.0), Wc = rng.uniform(1.8, 3.0), H = rng.uniform(2.5, 3.0);
  const double Dr = rng.uniform(3.0, 5.0);
  layout.ceiling_height = H;
  scene.polygon("floor", {V3(0, 0, 0), V3(L, 0, 0), V3(L, Wc + Dr, 0), V3(0, Wc + Dr, 0)}, floorTexture(rng));
  scene.polygon("ceiling", {V3(0, 0, H), V3(L, 0, H), V3(L, Wc + Dr, H), V3(0, Wc + Dr, H)}, ceilingTexture(rng));
  WallSide south{"corridor_south", V2(0, 0), V2(L, 0), V2(0, 1), H, {}};
  WallSide north{"corridor_north", V2(L, Wc), V2(0, Wc), V2(0, -1), H, {}};
  WallSide west{"corridor_west", V2(0, Wc + Dr), V2(0, 0), V2(1, 0), H, {}};
  WallSide east{"corridor_east", V2(L, 0), V2(L, Wc + Dr), V2(-1, 0), H, {}};
  std::vector<Opening> south_doors;
  for (int d = 0, n = rng.integer(1, 2); d < n; ++d)
    if (const double u = south.reserve(rng, 1.0); u >= 0.0)
      south_doors.push_back({u, 1.0, 2.1, 0.0});
  const Color paint = rng.color(kPaint);
  scene.wall(south.name, south.a, south.b, H, south_doors, wallTexture(rng, south, south_doors, paint));
  for (const Opening& o : south_doors)
    vestibule(scene, rng, south, o);
  corridorRooms(scene, rng, L, Wc, Dr, H, north);
  scene.wall(west.name, west.a, west.b, H, {}, wallTexture(rng, west, {}, rng.color(kPaint)));
  scene.wall(east.name, east.a, east.b, H, {}, wallTexture(rng, east, {}, rng.color(kPaint)));
  scene.plan.walkable = Eigen::AlignedBox2d(V2(0, 0), V2(L, Wc));
  Placer placer{scene, rng, scene.plan.walkable, {}};
  for (const auto& [a, b] : south.used)
    placer.taken.push_back({V2(a, 0), V2(b, 1.0)});
  for (const auto& [a, b] : north.used)
    placer.taken.push_back({V2(L - b, Wc - 1.0), V2(L - a, Wc)});
  decorate(scene, rng, south, true);
  decorate(scene, rng, north, false);
  WallSide west_corridor{"corridor_west", V2(0, Wc), V2(0, 0), V2(1, 0), H, {}};
  WallSide east_corridor{"corridor_east", V2(L, 0), V2(L, Wc), V2(-1, 0), H, {}};
  decorate(scene, rng, west_corridor, false);
  decorate(scene, rng, east_corridor, true);
  ceilingLights(scene, rng, scene.plan.walkable, H);
  if (Wc > 2.3)
    for (int k = 0, n = rng.integer(1, 3); k < n; ++k)
      placer.againstWall(rng.chance(0.6) ? bench(rng) : plant(rng), south);
  const V2 lo(0.25, 0.25), hi(L - 0.25, Wc - 0.25);
  layout.camera_sites = {lo,
                         V2(hi.x(), lo.y()),
                         hi,
                         V2(lo.x(), hi.y()),
                         V2(lo.x(), 0.5 * Wc),
                         V2(hi.x(), 0.5 * Wc),
                         V2(0.3 * L, lo.y()),
                         V2(0.7 * L, hi.y())};
  char text[128];
  std::snprintf(text, sizeof(text), "Corridor %.1f x %.1f x %.1f m with rooms %.1f m deep", L, Wc, H, Dr);
  layout.description = text;
  return layout;
}
}  // namespace

Layout buildLayout(BuildingKind kind, Rng& rng)
{
  switch (kind)
  {
    case BuildingKind::kHall:
      return buildHall(rng);
    case BuildingKind::kCorridor:
      return buildCorridor(rng);
    case BuildingKind::kOffice:
      return buildOffice(rng);
    default:
      return buildRoom(rng);
  }
}

}  // namespace generator
}  // namespace simulation
}  // namespace insitu_calibration
