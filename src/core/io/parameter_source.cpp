#include "insitu_calibration/io/parameter_source.h"

#include "insitu_calibration/io/atomic_file.h"
#include "io/yaml_util.h"

namespace insitu_calibration
{
int ParameterSource::integer(const std::string& name, int fallback, ParameterRange range)
{
  range.integer = true;
  return static_cast<int>(number(name, fallback, range));
}

std::string ParameterSource::summary() const
{
  std::string text;
  for (const std::string& error : errors_)
    text += (text.empty() ? "" : "; ") + error;
  return text;
}

namespace
{
// Walks the nested maps below node, recording every leaf under its '/'-joined name.
template <typename Record>
void flatten(const yaml_util::YamlNode& node, const std::string& prefix, Record&& record)
{
  for (const auto& entry : node)
  {
    const std::string name = prefix + entry.first.Scalar();
    if (entry.second.IsMap())
      flatten(entry.second, name + "/", record);
    else
      record(name, entry.second);
  }
}
}  // namespace

Expected<YamlParameterSource> YamlParameterSource::parse(const std::string& yaml_text, const std::string& source)
{
  return yaml_util::guarded<YamlParameterSource>(source, [&]() -> Expected<YamlParameterSource> {
    const auto tree = yaml_util::parseYaml(yaml_text, source);
    if (!tree)
      return tree.error();
    const yaml_util::YamlNode root = tree->root();
    if (!root.IsMap() && !root.IsNull())
      return Error(ErrorCode::kParseError, source + ": expected a map of parameters (name: value)");
    YamlParameterSource out;
    out.source_ = source;
    if (root.IsNull())
      return out;
    flatten(root, "", [&](const std::string& name, const yaml_util::YamlNode& node) {
      Value value;
      if (node.IsSequence())
        value.description = "a list of " + std::to_string(node.size());
      else if (node.IsScalar())
      {
        const std::string text = node.Scalar();
        if (yaml_util::decodeBool(text, value.boolean))
          value.kind = Value::Kind::kBoolean;
        else if (yaml_util::decodeNumber(text, value.number))
          value.kind = Value::Kind::kNumber;
        else
          value.description = "the string '" + text + "'";
      }
      else
        value.description = "an empty value";
      out.values_[name] = value;
    });
    return out;
  });
}

Expected<YamlParameterSource> YamlParameterSource::load(const std::string& path)
{
  const auto text = readFile(path);
  if (!text)
    return text.error();
  return parse(*text, path);
}

double YamlParameterSource::number(const std::string& name, double fallback, const ParameterRange& range)
{
  const auto it = values_.find(name);
  if (it == values_.end())
    return fallback;
  const Value& value = it->second;
  if (value.kind != Value::Kind::kNumber)
  {
    const std::string what = value.kind == Value::Kind::kBoolean
                                 ? (value.boolean ? "the boolean true" : "the boolean false")
                                 : value.description;
    errors_.push_back(source_ + ": " + parameterTypeError(name, what, range).message());
    return fallback;
  }
  const Status checked = checkParameter(name, value.number, range);
  if (!checked)
  {
    errors_.push_back(source_ + ": " + checked.error().message());
    return fallback;
  }
  return value.number;
}

bool YamlParameterSource::flag(const std::string& name, bool fallback)
{
  const auto it = values_.find(name);
  if (it == values_.end())
    return fallback;
  if (it->second.kind != Value::Kind::kBoolean)
  {
    const std::string what = it->second.kind == Value::Kind::kNumber
                                 ? "the number " + formatParameterValue(it->second.number)
                                 : it->second.description;
    errors_.push_back(source_ + ": parameter ~" + name + " is " + what + ", allowed: true or false");
    return fallback;
  }
  return it->second.boolean;
}
}  // namespace insitu_calibration
