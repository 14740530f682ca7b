#include "insitu_calibration/robust_statistics.h"

#include <algorithm>
#include <cmath>

namespace insitu_calibration
{
double middleValue(std::vector<double> values)
{
  if (values.empty())
    return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  return values[mid];
}

double robustSigma(std::vector<double> absolute_residuals)
{
  return kMadToSigma * middleValue(std::move(absolute_residuals));
}

double rootMeanSquare(const std::vector<double>& values)
{
  if (values.empty())
    return 0.0;
  double sum = 0.0;
  for (double v : values)
    sum += v * v;
  return std::sqrt(sum / values.size());
}
}  // namespace insitu_calibration
