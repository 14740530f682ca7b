// A small command-line parser shared by the tools: --name value, --name=value, --flag, positionals, --help.
#ifndef INSITU_CALIBRATION_TOOLS_COMMAND_LINE_H
#define INSITU_CALIBRATION_TOOLS_COMMAND_LINE_H

#include <cstdlib>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace insitu_calibration
{
class CommandLine
{
public:
  // value_options take a value; flags do not. Unknown options are an error.
  CommandLine(int argc, char** argv, const std::set<std::string>& value_options, const std::set<std::string>& flags)
  {
    for (int i = 1; i < argc; ++i)
    {
      std::string arg = argv[i];
      if (arg == "-h" || arg == "--help")
      {
        help_ = true;
        continue;
      }
      if (arg.rfind("--", 0) != 0 || arg.size() == 2)
      {
        positional_.push_back(arg);
        continue;
      }
      std::string name = arg.substr(2);
      std::string value;
      bool has_value = false;
      if (const auto eq = name.find('='); eq != std::string::npos)
      {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
        has_value = true;
      }
      if (flags.count(name))
      {
        flags_.insert(name);
        continue;
      }
      if (!value_options.count(name))
      {
        error_ = "unknown option --" + name;
        continue;
      }
      if (!has_value)
      {
        if (i + 1 >= argc)
        {
          error_ = "option --" + name + " needs a value";
          continue;
        }
        value = argv[++i];
      }
      values_[name] = value;
    }
  }

  bool help() const { return help_; }
  const std::string& error() const { return error_; }
  const std::vector<std::string>& positional() const { return positional_; }
  bool flag(const std::string& name) const { return flags_.count(name) > 0; }
  bool has(const std::string& name) const { return values_.count(name) > 0; }
  std::string value(const std::string& name, const std::string& fallback = "") const
  {
    const auto it = values_.find(name);
    return it == values_.end() ? fallback : it->second;
  }
  // The items of a comma-separated value (e.g. several files), empty ones left out.
  std::vector<std::string> items(const std::string& name) const
  {
    std::vector<std::string> out;
    std::stringstream list(value(name));
    for (std::string item; std::getline(list, item, ',');)
      if (!item.empty())
        out.push_back(item);
    return out;
  }
  // Numbers: sets error() when the value is not a number.
  double number(const std::string& name, double fallback)
  {
    if (!has(name))
      return fallback;
    const std::string v = value(name);
    char* end = nullptr;
    const double x = std::strtod(v.c_str(), &end);
    if (v.empty() || *end != '\0')
    {
      error_ = "option --" + name + ": '" + v + "' is not a number";
      return fallback;
    }
    return x;
  }
  // ... and when it lies outside [lo, hi].
  double number(const std::string& name, double fallback, double lo, double hi)
  {
    const double x = number(name, fallback);
    if (has(name) && error_.empty() && !(x >= lo && x <= hi))
    {
      error_ =
          "option --" + name + ": " + value(name) + " is outside [" + shortNumber(lo) + ", " + shortNumber(hi) + "]";
      return fallback;
    }
    return x;
  }

private:
  static std::string shortNumber(double x)
  {
    std::ostringstream out;
    out << x;
    return out.str();
  }

  bool help_ = false;
  std::string error_;
  std::vector<std::string> positional_;
  std::map<std::string, std::string> values_;
  std::set<std::string> flags_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_TOOLS_COMMAND_LINE_H
