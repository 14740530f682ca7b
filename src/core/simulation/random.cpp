#include "insitu_calibration/simulation/random.h"

#include <cmath>

namespace insitu_calibration
{
namespace simulation
{
namespace
{
// Acklam's rational approximation of the standard normal quantile (relative error below 1.2e-9).
double normalQuantile(double p)
{
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                             1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                             6.680131188771972e+01, -1.328068155288572e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                             -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                             3.754408661907416e+00};
  const double p_low = 0.02425;
  if (p < p_low)
  {
    const double q = std::sqrt(-2.0 * std::log(p));
    return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
           ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  }
  if (p > 1.0 - p_low)
    return -normalQuantile(1.0 - p);
  const double q = p - 0.5;
  const double r = q * q;
  return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
         (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
}

std::array<float, 4096> makeTable()
{
  std::array<double, 4096> values;
  double sum2 = 0.0;
  for (size_t i = 0; i < values.size(); ++i)
  {
    values[i] = normalQuantile((static_cast<double>(i) + 0.5) / values.size());
    sum2 += values[i] * values[i];
  }
  // Symmetric, so the mean is zero; scale to unit variance.
  const double scale = 1.0 / std::sqrt(sum2 / values.size());
  std::array<float, 4096> table;
  for (size_t i = 0; i < values.size(); ++i)
    table[i] = static_cast<float>(values[i] * scale);
  return table;
}
}  // namespace

uint64_t streamSeed(uint64_t seed, uint64_t a, uint64_t b, uint64_t c)
{
  uint64_t state = seed;
  uint64_t h = splitMix64(state);
  for (const uint64_t key : {a, b, c})
  {
    state = h ^ (key * 0xD1B54A32D192ED03ULL);
    h = splitMix64(state);
  }
  return h;
}

FastRandom::FastRandom(uint64_t seed)
{
  uint64_t state = seed;
  for (uint64_t& s : s_)
    s = splitMix64(state);
}

double FastRandom::exactGaussian()
{
  double u1 = uniform();
  while (u1 <= 0.0)
    u1 = uniform();
  const double u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

const std::array<float, 4096>& FastRandom::table()
{
  static const std::array<float, 4096> table = makeTable();
  return table;
}

}  // namespace simulation
}  // namespace insitu_calibration
