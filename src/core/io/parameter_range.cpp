#include "insitu_calibration/io/parameter_range.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace insitu_calibration
{
ParameterRange ParameterRange::closed(double min, double max, std::string unit)
{
  ParameterRange range;
  range.min = min;
  range.max = max;
  range.unit = std::move(unit);
  return range;
}

ParameterRange ParameterRange::positive(double max, std::string unit)
{
  ParameterRange range = closed(0.0, max, std::move(unit));
  range.min_open = true;
  return range;
}

ParameterRange ParameterRange::integers(int min, int max)
{
  ParameterRange range = closed(min, max);
  range.integer = true;
  return range;
}

std::string ParameterRange::describe() const
{
  std::string text = integer ? "an integer in " : "a number in ";
  text +=
      (min_open ? "(" : "[") + formatParameterValue(min) + ", " + formatParameterValue(max) + (max_open ? ")" : "]");
  return unit.empty() ? text : text + " " + unit;
}

bool ParameterRange::contains(double value) const
{
  if (!std::isfinite(value) || (integer && value != std::floor(value)))
    return false;
  const bool above_min = min_open ? value > min : value >= min;
  const bool below_max = max_open ? value < max : value <= max;
  return above_min && below_max;
}

std::string formatParameterValue(double value)
{
  if (std::isnan(value))
    return "nan";
  if (std::isinf(value))
    return value > 0 ? "inf" : "-inf";
  // The fewest significant digits that read back the same (0.2, not 0.20000000000000001), and enough of them for
  // numbers from 1e-4 to 1e17 to be written out (60, not 6e+01).
  const int exponent = value == 0.0 ? 0 : static_cast<int>(std::floor(std::log10(std::abs(value))));
  int digits = 1;
  for (; digits < 17; ++digits)
  {
    std::ostringstream shorter;
    shorter.precision(digits);
    shorter << value;
    if (std::strtod(shorter.str().c_str(), nullptr) == value)
      break;
  }
  std::ostringstream out;
  out.precision(exponent < 17 ? std::max(digits, exponent + 1) : digits);
  out << value;
  return out.str();
}

Status checkParameter(const std::string& name, double value, const ParameterRange& range)
{
  if (range.contains(value))
    return Success{};
  return Error(ErrorCode::kInvalidInput,
               "parameter ~" + name + " is " + formatParameterValue(value) + ", allowed: " + range.describe());
}

Error parameterTypeError(const std::string& name, const std::string& what_it_is, const ParameterRange& range)
{
  return Error(ErrorCode::kInvalidInput, "parameter ~" + name + " is " + what_it_is + ", allowed: " + range.describe());
}
}  // namespace insitu_calibration
