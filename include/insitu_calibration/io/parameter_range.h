// The allowed values of a numeric configuration parameter (a node's ROS parameter): finite, within a range, an
// integer where one is due. One home for the check and its message, which names the parameter, its value and the
// allowed range; the ROS layer reads the values (ros/parameter_reader.h) and reports the errors as FATAL.
#ifndef INSITU_CALIBRATION_IO_PARAMETER_RANGE_H
#define INSITU_CALIBRATION_IO_PARAMETER_RANGE_H

#include <string>

#include "insitu_calibration/error.h"

namespace insitu_calibration
{
struct ParameterRange
{
  double min = 0.0;
  double max = 0.0;
  bool min_open = false;  // min itself is refused: (min, max]
  bool max_open = false;
  bool integer = false;
  std::string unit;  // "s", "m", "px", ... (empty: a count or a ratio)

  // Shorthands: [min, max], (min, max] and an integer in [min, max].
  static ParameterRange closed(double min, double max, std::string unit = "");
  static ParameterRange positive(double max, std::string unit = "");
  static ParameterRange integers(int min, int max);

  // "a number in (0, 60] s", "an integer in [1, 255]".
  std::string describe() const;
  bool contains(double value) const;
};

// Ok when value is finite, in range and (if due) an integer; otherwise an kInvalidInput error such as
// "parameter ~tf_timeout is -1, allowed: a number in [0, 60] s".
Status checkParameter(const std::string& name, double value, const ParameterRange& range);
// The error for a parameter of the wrong type ("parameter ~tf_timeout is the string 'fast', allowed: ...").
Error parameterTypeError(const std::string& name, const std::string& what_it_is, const ParameterRange& range);
// A number as a message shows it: shortest round-trip form, "nan", "inf".
std::string formatParameterValue(double value);
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_IO_PARAMETER_RANGE_H
