// Internal to the world generator: a random source, and a scene that writes world-file entries (surfaces) while it
// records what the route planner and the camera placement need (obstacle footprints, solid boxes, wall sides).
#ifndef INSITU_CALIBRATION_SIMULATION_GENERATOR_SCENE_H
#define INSITU_CALIBRATION_SIMULATION_GENERATOR_SCENE_H

#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "insitu_calibration/simulation/random.h"
#include "insitu_calibration/simulation/route_planner.h"
#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace simulation
{
namespace generator
{
class Rng
{
public:
  Rng(uint64_t seed, uint64_t stream) : random_(streamSeed(seed, stream)) {}
  double uniform(double a, double b) { return a + (b - a) * random_.uniform(); }
  int integer(int a, int b) { return std::min(b, a + static_cast<int>(random_.uniform() * (b - a + 1))); }
  bool chance(double p) { return random_.uniform() < p; }
  double gaussian() { return random_.exactGaussian(); }
  Color color(const std::vector<Color>& palette, double jitter = 12.0);

private:
  FastRandom random_;
};

// Numbers as the world files write them (mm precision, no trailing zeros).
std::string num(double x);
std::string vec(std::initializer_list<double> v);
std::string vec2(const Eigen::Vector2d& v);
std::string vec3(const Eigen::Vector3d& v);
std::string textureYaml(const Texture& t);

struct Box3
{
  Eigen::Vector3d min, max;  // axis-aligned (the generator turns furniture by quarter turns only)
};

// One side of a wall seen from the space it bounds: u runs from a to b, inward points into the space.
struct WallSide
{
  std::string name;
  Eigen::Vector2d a, b;
  Eigen::Vector2d inward;
  double height = 3.0;
  std::vector<std::pair<double, double>> used;  // u intervals taken by openings and decorations

  double length() const { return (b - a).norm(); }
  Eigen::Vector2d direction() const { return (b - a).normalized(); }
  Eigen::Vector2d at(double u) const { return a + u * direction(); }
  // A free interval of this width (0.3 m from the ends, 0.2 m from anything else), or a negative number.
  double reserve(Rng& rng, double width);
};

struct Opening
{
  double offset, width, height, sill;
};

class Scene
{
public:
  std::string uniqueName(const std::string& base);
  void polygon(const std::string& name, const std::vector<Eigen::Vector3d>& points, const Texture& texture);
  void rectangle(const std::string& name, const Eigen::Vector3d& center, const Eigen::Vector3d& normal,
                 const Eigen::Vector2d& size, const Texture& texture);
  // obstacle: the robot must keep clear of its footprint (everything standing below its height).
  void box(const std::string& name, const Box3& box, const Texture& texture, bool obstacle = true,
           double yaw_deg = 0.0);
  void wall(const std::string& name, const Eigen::Vector2d& from, const Eigen::Vector2d& to, double height,
            const std::vector<Opening>& openings, const Texture& texture);
  // A rectangle on a wall side (2-6 mm in front of it): u of its centre, v of its centre, size.
  void onWall(const std::string& name, const WallSide& side, double u, double v, const Eigen::Vector2d& size,
              const Texture& texture, double lift = 0.002);

  // The surfaces' YAML; with a seed, every texture dressed as a material with natural structure (drawn from a stream
  // of its own, so that the geometry is the same either way).
  std::string surfaces(std::optional<uint64_t> materials_seed = std::nullopt) const;
  FloorPlan plan;
  std::vector<Box3> solids;  // for the cameras' lines of sight

private:
  enum class Kind
  {
    kFloor,
    kCeiling,
    kWall,
    kOther
  };
  struct Entry
  {
    std::string head;  // the surface's YAML up to its texture
    Kind kind;
    Texture texture;
  };
  void add(Kind kind, const Texture& texture);
  static Texture dress(Kind kind, Texture texture, Rng& rng);

  std::vector<Entry> entries_;
  std::ostringstream out_;  // the surface being written
  std::set<std::string> names_;
};

}  // namespace generator
}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_GENERATOR_SCENE_H
