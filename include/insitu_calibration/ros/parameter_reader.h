// Reads a node's private parameters as checked input: a parameter that is set must have the right type, and a
// number must be finite and within its range (io/parameter_range.h); an unset one takes its default. The errors are
// collected, so that a node reports every bad parameter at once (ROS_FATAL) and exits with status 1.
#ifndef INSITU_CALIBRATION_ROS_PARAMETER_READER_H
#define INSITU_CALIBRATION_ROS_PARAMETER_READER_H

#include <string>
#include <vector>

#include <ros/node_handle.h>

#include "insitu_calibration/io/parameter_range.h"

namespace insitu_calibration
{
class ParameterReader
{
public:
  explicit ParameterReader(const ros::NodeHandle& private_nh) : nh_(private_nh) {}

  // A number (an integer parameter is accepted where a number is due); fallback when unset.
  double number(const std::string& name, double fallback, const ParameterRange& range);
  // An integer (range.integer is implied).
  int integer(const std::string& name, int fallback, ParameterRange range);
  // A list of exactly size numbers, each in range ([x, y, z], say).
  std::vector<double> numbers(const std::string& name, const std::vector<double>& fallback, size_t size,
                              const ParameterRange& range);
  bool flag(const std::string& name, bool fallback);
  // A string; an empty one is an error unless allow_empty.
  std::string text(const std::string& name, const std::string& fallback, bool allow_empty);
  // An error found by the caller (a relation between parameters, say), reported with the others.
  void fail(const std::string& message) { errors_.push_back(message); }

  bool ok() const { return errors_.empty(); }
  // Every error, "; "-separated (empty when ok).
  std::string summary() const;
  // "parameter ~tf_timeout is -1, allowed: a number in [0, 60] s", one per bad parameter.
  const std::vector<std::string>& errors() const { return errors_; }

private:
  ros::NodeHandle nh_;
  std::vector<std::string> errors_;
};
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ROS_PARAMETER_READER_H
