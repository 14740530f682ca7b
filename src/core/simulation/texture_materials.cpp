// Materials with natural structure (Texture: planks, bricks, tiles; variation, grain, speckle, gradient): procedural
// and deterministic from the texture's seed, evaluated at any (u, v) so that the renderer's anti-aliasing samples
// them exactly like the plain patterns.
#include <cmath>
#include <cstdint>

#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace simulation
{
namespace
{
enum Salt : uint64_t
{
  kRowSalt = 1,
  kUnitSalt = 2,
  kGrainSalt = 3,
  kSpeckleSalt = 4,
  kGradientSalt = 5,
};

uint64_t mix(uint64_t x)
{
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// Uniform in [0, 1) from the seed, two integer coordinates and a salt.
double hash01(uint32_t seed, long i, long j, uint64_t salt)
{
  const uint64_t h =
      mix(mix(mix((static_cast<uint64_t>(seed) << 8) ^ salt) + static_cast<uint64_t>(i)) + static_cast<uint64_t>(j));
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}

// Smooth value noise in [-1, 1] with unit lattice spacing.
double valueNoise(uint32_t seed, double x, double y, uint64_t salt)
{
  const double fx = std::floor(x), fy = std::floor(y);
  const long i = static_cast<long>(fx), j = static_cast<long>(fy);
  double tx = x - fx, ty = y - fy;
  tx = tx * tx * (3.0 - 2.0 * tx);
  ty = ty * ty * (3.0 - 2.0 * ty);
  const double a = hash01(seed, i, j, salt), b = hash01(seed, i + 1, j, salt);
  const double c = hash01(seed, i, j + 1, salt), d = hash01(seed, i + 1, j + 1, salt);
  return 2.0 * ((1 - ty) * ((1 - tx) * a + tx * b) + ty * ((1 - tx) * c + tx * d)) - 1.0;
}
}  // namespace

double Texture::rowShift(long row) const
{
  if (pattern == Pattern::kBricks)
    return (row & 1) ? 0.5 * cell.x() : 0.0;
  if (pattern == Pattern::kPlanks)
    return hash01(seed, row, 0, kRowSalt) * cell.x();
  return 0.0;
}

int Texture::materialRegion(double u, double v, Eigen::Vector2i* unit) const
{
  const double a = u - offset.x(), b = v - offset.y();
  const long row = static_cast<long>(std::floor(b / cell.y()));
  const double shifted = a - rowShift(row);
  const long column = static_cast<long>(std::floor(shifted / cell.x()));
  *unit = Eigen::Vector2i(static_cast<int>(column), static_cast<int>(row));
  const double along = shifted - column * cell.x(), across = b - row * cell.y();
  return (along < joint || across < joint) ? 1 : 0;
}

float Texture::structure(double u, double v, int region) const
{
  double f = 1.0;
  const bool base = region < 2;                            // not under a rectangle
  const bool unit = base && !(material() && region == 1);  // not a joint
  if (unit && material() && variation > 0.0)
  {
    Eigen::Vector2i index;
    materialRegion(u, v, &index);
    f *= 1.0 + variation * (2.0 * hash01(seed, index.x(), index.y(), kUnitSalt) - 1.0);
  }
  if (unit && grain > 0.0)
  {
    // The growth rings of a sawn board: streaks along u, 1.5-3 cm apart, waving and fading along the board, each
    // board (unit) cut from elsewhere in the log (its own phase, spacing and wave), so no streak crosses a joint.
    Eigen::Vector2i board(0, 0);
    if (material())
      materialRegion(u, v, &board);
    const double h1 = hash01(seed, board.x(), board.y(), kGrainSalt);
    const double h2 = hash01(seed, board.x(), board.y(), kGrainSalt + 8);
    const double wave = valueNoise(seed, 1.5 * u + 97.0 * h1, 4.0 * v + 31.0 * h2, kGrainSalt);
    const double s = 0.5 + 0.5 * std::sin(2.0 * M_PI * ((35.0 + 30.0 * h2) * v + 2.5 * wave + h1));
    const double fade = 0.5 + 0.5 * valueNoise(seed, 2.0 * u + 53.0 * h2, 10.0 * v, kGrainSalt + 4);
    f *= 1.0 - 0.2 * grain * s * s * fade + 0.08 * grain * valueNoise(seed, 3.0 * u, 25.0 * v, kGrainSalt + 16);
  }
  if (unit && speckle > 0.0)
    f *= 1.0 + 0.3 * speckle *
                   (2.0 * hash01(seed, static_cast<long>(std::floor(u / 0.003)),
                                 static_cast<long>(std::floor(v / 0.003)), kSpeckleSalt) -
                    1.0);
  if (gradient > 0.0)
    f *= 1.0 + gradient * valueNoise(seed, u / 1.5, v / 1.5, kGradientSalt);
  return static_cast<float>(std::max(0.0, f));
}

}  // namespace simulation
}  // namespace insitu_calibration
