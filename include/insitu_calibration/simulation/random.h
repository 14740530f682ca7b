// Fast deterministic random numbers for the simulator's sensor noise: xoshiro256** streams seeded through
// SplitMix64 from (seed, stream key), so every image's noise depends only on the seed and on what the image is, never
// on the order in which images are made. Gaussian samples come from a 4096-entry inverse-CDF table (about 1.5 ns a
// sample instead of about 20 for std::normal_distribution); the table is scaled to unit variance exactly and its
// tails end at 3.7 sigma, which is plenty for sensor noise.
#ifndef INSITU_CALIBRATION_SIMULATION_RANDOM_H
#define INSITU_CALIBRATION_SIMULATION_RANDOM_H

#include <array>
#include <cstdint>

namespace insitu_calibration
{
namespace simulation
{
// SplitMix64: a good 64-bit mixer, also used to derive stream seeds.
inline uint64_t splitMix64(uint64_t& state)
{
  uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// A seed for the stream identified by (seed, a, b, c), e.g. (seed, kind of image, camera index, frame index).
uint64_t streamSeed(uint64_t seed, uint64_t a, uint64_t b = 0, uint64_t c = 0);

class FastRandom
{
public:
  explicit FastRandom(uint64_t seed);

  uint64_t next()
  {
    const uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  // Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  // Standard normal sample (table based, see above).
  float gaussian()
  {
    if (cached_ == 0)
    {
      bits_ = next();
      cached_ = 5;
    }
    const float g = table()[bits_ & 4095u];
    bits_ >>= 12;
    --cached_;
    return g;
  }
  // Exact standard normal sample (Box-Muller with the full generator), for the rare places that need real tails.
  double exactGaussian();

  static const std::array<float, 4096>& table();

private:
  static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  uint64_t s_[4];
  uint64_t bits_ = 0;
  int cached_ = 0;
};

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_RANDOM_H
