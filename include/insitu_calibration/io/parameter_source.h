// Where a program's named, checked parameters come from: calibration_node's private ROS parameters
// (ros/parameter_reader.h) or a YAML file holding the same names (YamlParameterSource, read by calibrate_survey). A
// reader of options (survey/survey_parameters.h) takes either, so each parameter's name, default and range are
// written once. A parameter that is set must have the right type and lie in its range (io/parameter_range.h); an
// unset one takes the default given. Errors are collected, so that every bad parameter is reported at once.
#ifndef INSITU_CALIBRATION_IO_PARAMETER_SOURCE_H
#define INSITU_CALIBRATION_IO_PARAMETER_SOURCE_H

#include <map>
#include <string>
#include <vector>

#include "insitu_calibration/error.h"
#include "insitu_calibration/io/parameter_range.h"

namespace insitu_calibration
{
class ParameterSource
{
public:
  virtual ~ParameterSource() = default;

  // A number (an integer is accepted where a number is due); fallback when unset or wrong (with an error).
  virtual double number(const std::string& name, double fallback, const ParameterRange& range) = 0;
  virtual bool flag(const std::string& name, bool fallback) = 0;
  // Whether the parameter is set (whatever its value): for a default that depends on it being given.
  virtual bool has(const std::string& name) const = 0;
  // An integer (range.integer is implied): a number with an integral value (2.0) is accepted, 2.5 is not.
  int integer(const std::string& name, int fallback, ParameterRange range);
  // An error found by the caller (a relation between parameters, say), reported with the others.
  void fail(const std::string& message) { errors_.push_back(message); }

  bool ok() const { return errors_.empty(); }
  // Every error, "; "-separated (empty when ok).
  std::string summary() const;
  // "parameter ~tf_timeout is -1, allowed: a number in [0, 60] s", one per bad parameter.
  const std::vector<std::string>& errors() const { return errors_; }

protected:
  std::vector<std::string> errors_;
};

// The parameters of a YAML map as a ROS parameter server holds a node's private namespace after `rosparam load`:
// nested maps give names with '/' (keyframe: {min_translation: 0.2} is keyframe/min_translation). Other keys (the
// camera list, say) are ignored unless asked for.
class YamlParameterSource : public ParameterSource
{
public:
  // kParseError for malformed YAML or a document that is not a map; source names the file in messages.
  static Expected<YamlParameterSource> parse(const std::string& yaml_text, const std::string& source);
  static Expected<YamlParameterSource> load(const std::string& path);

  double number(const std::string& name, double fallback, const ParameterRange& range) override;
  bool flag(const std::string& name, bool fallback) override;
  bool has(const std::string& name) const override { return values_.count(name) > 0; }

private:
  struct Value
  {
    enum class Kind
    {
      kNumber,
      kBoolean,
      kOther  // a string, a list or a map: described for the message
    };
    Kind kind = Kind::kOther;
    double number = 0.0;
    bool boolean = false;
    std::string description;  // "the string 'fast'", "a list of 3", "a map"
  };
  std::map<std::string, Value> values_;
  std::string source_;
};
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_IO_PARAMETER_SOURCE_H
