#include "insitu_calibration/ros/parameter_reader.h"

#include <xmlrpcpp/XmlRpcValue.h>

namespace insitu_calibration
{
namespace
{
// What a parameter of an unexpected type holds, for the message: "the string 'fast'", "a list".
std::string describeValue(XmlRpc::XmlRpcValue& value)
{
  switch (value.getType())
  {
    case XmlRpc::XmlRpcValue::TypeString:
      return "the string '" + static_cast<std::string>(value) + "'";
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(value) ? "the boolean true" : "the boolean false";
    case XmlRpc::XmlRpcValue::TypeInt:
      return "the integer " + std::to_string(static_cast<int>(value));
    case XmlRpc::XmlRpcValue::TypeDouble:
      return "the number " + formatParameterValue(static_cast<double>(value));
    case XmlRpc::XmlRpcValue::TypeArray:
      return "a list of " + std::to_string(value.size());
    case XmlRpc::XmlRpcValue::TypeStruct:
      return "a map";
    default:
      return "a value of another type";
  }
}
}  // namespace

double ParameterReader::number(const std::string& name, double fallback, const ParameterRange& range)
{
  XmlRpc::XmlRpcValue value;
  if (!nh_.getParam(name, value))
    return fallback;
  double number = fallback;
  if (value.getType() == XmlRpc::XmlRpcValue::TypeDouble)
    number = static_cast<double>(value);
  else if (value.getType() == XmlRpc::XmlRpcValue::TypeInt)
    number = static_cast<int>(value);
  else
  {
    errors_.push_back(parameterTypeError(name, describeValue(value), range).message());
    return fallback;
  }
  const Status checked = checkParameter(name, number, range);
  if (!checked)
  {
    errors_.push_back(checked.error().message());
    return fallback;
  }
  return number;
}

std::vector<double> ParameterReader::numbers(const std::string& name, const std::vector<double>& fallback, size_t size,
                                             const ParameterRange& range)
{
  XmlRpc::XmlRpcValue value;
  if (!nh_.getParam(name, value))
    return fallback;
  const std::string allowed = "a list of " + std::to_string(size) + " numbers, each " + range.describe();
  if (value.getType() != XmlRpc::XmlRpcValue::TypeArray || static_cast<size_t>(value.size()) != size)
  {
    errors_.push_back("parameter ~" + name + " is " + describeValue(value) + ", allowed: " + allowed);
    return fallback;
  }
  std::vector<double> numbers;
  for (int i = 0; i < value.size(); ++i)
  {
    const XmlRpc::XmlRpcValue::Type type = value[i].getType();
    if (type != XmlRpc::XmlRpcValue::TypeDouble && type != XmlRpc::XmlRpcValue::TypeInt)
    {
      errors_.push_back("parameter ~" + name + "[" + std::to_string(i) + "] is " + describeValue(value[i]) +
                        ", allowed: " + allowed);
      return fallback;
    }
    numbers.push_back(type == XmlRpc::XmlRpcValue::TypeDouble ? static_cast<double>(value[i])
                                                              : static_cast<int>(value[i]));
    const Status checked = checkParameter(name + "[" + std::to_string(i) + "]", numbers.back(), range);
    if (!checked)
    {
      errors_.push_back(checked.error().message());
      return fallback;
    }
  }
  return numbers;
}

bool ParameterReader::flag(const std::string& name, bool fallback)
{
  XmlRpc::XmlRpcValue value;
  if (!nh_.getParam(name, value))
    return fallback;
  if (value.getType() != XmlRpc::XmlRpcValue::TypeBoolean)
  {
    errors_.push_back("parameter ~" + name + " is " + describeValue(value) + ", allowed: true or false");
    return fallback;
  }
  return static_cast<bool>(value);
}

std::string ParameterReader::text(const std::string& name, const std::string& fallback, bool allow_empty)
{
  XmlRpc::XmlRpcValue value;
  if (!nh_.getParam(name, value))
    return fallback;
  if (value.getType() != XmlRpc::XmlRpcValue::TypeString)
  {
    errors_.push_back("parameter ~" + name + " is " + describeValue(value) + ", allowed: a string");
    return fallback;
  }
  const std::string text = static_cast<std::string>(value);
  if (text.empty() && !allow_empty)
  {
    errors_.push_back("parameter ~" + name + " is empty, allowed: a non-empty string");
    return fallback;
  }
  return text;
}
}  // namespace insitu_calibration
