// Reads a node's private parameters as checked input (a ParameterSource, io/parameter_source.h): a parameter that is
// set must have the right type, and a number must be finite and within its range (io/parameter_range.h); an unset
// one takes its default. The errors are collected, so that a node reports every bad parameter at once (ROS_FATAL)
// and exits with status 1.
#ifndef INSITU_CALIBRATION_ROS_PARAMETER_READER_H
#define INSITU_CALIBRATION_ROS_PARAMETER_READER_H

#include <string>
#include <vector>

#include <ros/node_handle.h>

#include "insitu_calibration/io/parameter_range.h"
#include "insitu_calibration/io/parameter_source.h"

namespace insitu_calibration
{
class ParameterReader : public ParameterSource
{
public:
  explicit ParameterReader(const ros::NodeHandle& private_nh) : nh_(private_nh) {}

  // A number (an integer parameter is accepted where a number is due); fallback when unset.
  double number(const std::string& name, double fallback, const ParameterRange& range) override;
  bool flag(const std::string& name, bool fallback) override;
  bool has(const std::string& name) const override { return nh_.hasParam(name); }
  // A list of exactly size numbers, each in range ([x, y, z], say).
  std::vector<double> numbers(const std::string& name, const std::vector<double>& fallback, size_t size,
                              const ParameterRange& range);
  // A string; an empty one is an error unless allow_empty.
  std::string text(const std::string& name, const std::string& fallback, bool allow_empty);

private:
  ros::NodeHandle nh_;
};
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ROS_PARAMETER_READER_H
