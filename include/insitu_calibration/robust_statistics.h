// Robust statistics used across the core: one home for the median, the MAD-based noise level and the RMS.
#ifndef INSITU_CALIBRATION_ROBUST_STATISTICS_H
#define INSITU_CALIBRATION_ROBUST_STATISTICS_H

#include <vector>

namespace insitu_calibration
{
// The standard deviation of a normal distribution per unit of its median absolute deviation.
constexpr double kMadToSigma = 1.4826;

// The middle element (of an even count, the upper of the two middle ones: no averaging, an element of the data);
// 0 for no data. Takes a copy: the order of the caller's data is kept.
double middleValue(std::vector<double> values);

// The noise level of residuals about zero from their absolute values: kMadToSigma x their middle value; robust to
// up to half of them being outliers. 0 for no data.
double robustSigma(std::vector<double> absolute_residuals);

// Root mean square; 0 for no data.
double rootMeanSquare(const std::vector<double>& values);
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ROBUST_STATISTICS_H
