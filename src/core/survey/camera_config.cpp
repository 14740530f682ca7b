#include "insitu_calibration/survey/camera_config.h"

#include <map>
#include <set>

#include "../io/yaml_util.h"
#include "insitu_calibration/io/atomic_file.h"

namespace insitu_calibration
{
namespace
{
constexpr size_t kMaxCameras = 256;
constexpr int kMaxImageSide = 32768;

std::string expandHome(const std::string& path)
{
  if (!path.empty() && path[0] == '~')
  {
    const char* home = std::getenv("HOME");
    return std::string(home ? home : "") + path.substr(1);
  }
  return path;
}

std::string calibratedInfoTopic(const std::string& image_topic)
{
  const auto slash = image_topic.rfind('/');
  return (slash == std::string::npos ? std::string() : image_topic.substr(0, slash)) + "/camera_info_calibrated";
}

Status readOptional(const yaml_util::YamlNode& map, const char* key, const std::string& where, double* out)
{
  if (!map[key])
    return Success{};
  const auto v = yaml_util::toDouble(map[key], where + "." + key);
  if (!v)
    return v.error();
  *out = *v;
  return Success{};
}

// A string entry: a scalar, or the fallback when absent (a list or map where a name is due is refused).
Expected<std::string> optionalText(const yaml_util::YamlNode& map, const char* key, const std::string& where,
                                   const std::string& fallback)
{
  const yaml_util::YamlNode value = map[key];
  if (!value)
    return fallback;
  if (!value.IsScalar() || value.Scalar().empty())
    return Error(ErrorCode::kParseError, where + "." + key + ": expected a non-empty string");
  return value.Scalar();
}

Expected<std::vector<CameraConfigEntry>> parseCameraList(const std::string& yaml_text);
}  // namespace

Expected<std::vector<CameraConfigEntry>> parseCameraConfig(const std::string& yaml_text)
{
  return yaml_util::guarded<std::vector<CameraConfigEntry>>("camera configuration",
                                                            [&] { return parseCameraList(yaml_text); });
}

namespace
{
Expected<CameraPrior> readPrior(const yaml_util::YamlNode& p, const std::string& pw)
{
  if (!p.IsMap())
    return Error(ErrorCode::kParseError, pw + ": expected a map {position, direction, horizontal_fov_deg}");
  CameraPrior prior;
  const auto position = yaml_util::toVector<3>(p["position"], pw + ".position");
  if (!position)
    return position.error();
  const auto direction = yaml_util::toVector<3>(p["direction"], pw + ".direction");
  if (!direction)
    return direction.error();
  const auto fov = yaml_util::toDouble(p["horizontal_fov_deg"], pw + ".horizontal_fov_deg");
  if (!fov)
    return fov.error();
  prior.position = *position;
  prior.direction = *direction;
  prior.horizontal_fov_deg = *fov;
  for (const auto& [key, target] : std::initializer_list<std::pair<const char*, double*>>{
           {"position_sigma_m", &prior.position_sigma_m},
           {"direction_sigma_deg", &prior.direction_sigma_deg},
           {"fov_sigma_relative", &prior.fov_sigma_relative},
           {"roll_deg", &prior.roll_deg},
           {"principal_point_sigma_px", &prior.principal_point_sigma_px}})
    if (const Status s = readOptional(p, key, pw, target); !s)
      return s.error();
  if (p["principal_point"])
  {
    const auto principal_point = yaml_util::toVector<2>(p["principal_point"], pw + ".principal_point");
    if (!principal_point)
      return principal_point.error();
    prior.principal_point = *principal_point;
  }
  if (!(prior.principal_point_sigma_px > 0.0))
    return Error(ErrorCode::kInvalidInput, pw + ".principal_point_sigma_px: must be positive");
  if (!(prior.direction.norm() > 0.0) || !(prior.horizontal_fov_deg > 0.0 && prior.horizontal_fov_deg < 180.0) ||
      !(prior.position_sigma_m > 0.0) || !(prior.direction_sigma_deg > 0.0) || !(prior.fov_sigma_relative > 0.0))
    return Error(ErrorCode::kInvalidInput, pw + ": the direction must be non-zero, the field of view between 0 "
                                                "and 180 degrees and every sigma positive");
  return prior;
}

// One camera of the list, checked on its own (the checks across cameras are the caller's).
Expected<CameraConfigEntry> readCameraEntry(const yaml_util::YamlNode& c, const std::string& where)
{
  if (!c.IsMap() || !c["name"])
    return Error(ErrorCode::kParseError, where + ": needs at least a name");
  CameraConfigEntry entry;
  FixedCameraConfig& config = entry.camera;
  const auto name = optionalText(c, "name", where, "");
  if (!name)
    return name.error();
  config.name = *name;
  const auto image_topic = optionalText(c, "image_topic", where, "/fixed/" + config.name + "/image_raw");
  if (!image_topic)
    return image_topic.error();
  config.image_topic = *image_topic;
  for (const char* key : {"image_width", "image_height"})
  {
    const auto v = yaml_util::toInt(c[key], where + "." + key);
    if (!v)
      return v.error();
    if (*v < 1 || *v > kMaxImageSide)
      return Error(ErrorCode::kInvalidInput,
                   where + "." + key + ": must be within 1.." + std::to_string(kMaxImageSide) + " px");
    (std::string(key) == "image_width" ? config.image_width : config.image_height) = *v;
  }
  const auto correspondence_file = optionalText(c, "correspondence_file", where, "");
  if (!correspondence_file)
    return correspondence_file.error();
  config.correspondence_file = expandHome(*correspondence_file);
  if (const yaml_util::YamlNode p = c["prior"])
  {
    auto prior = readPrior(p, where + ".prior");
    if (!prior)
      return prior.error();
    config.prior = *prior;
  }
  if (const Status valid = config.validate(); !valid)
    return Error(valid.error().code(), where + ": " + valid.error().message());
  const auto info_topic = optionalText(c, "calibrated_info_topic", where, calibratedInfoTopic(config.image_topic));
  if (!info_topic)
    return info_topic.error();
  entry.calibrated_info_topic = *info_topic;
  return entry;
}

Expected<std::vector<CameraConfigEntry>> parseCameraList(const std::string& yaml_text)
{
  const auto root = yaml_util::parseYaml(yaml_text, "camera configuration");
  if (!root)
    return root.error();
  const yaml_util::YamlNode doc = root->root();
  const yaml_util::YamlNode list = doc.IsMap() ? doc["cameras"] : doc;
  if (!list || !list.IsSequence() || list.size() == 0)
    return Error(ErrorCode::kParseError, "camera configuration: expected a non-empty list `cameras:`");
  if (const Status s = yaml_util::checkCount(list.size(), kMaxCameras, "camera configuration", "cameras"); !s)
    return s.error();
  std::vector<CameraConfigEntry> out;
  std::set<std::string> names;
  std::map<std::string, std::string> info_topics;  // topic -> camera
  for (size_t i = 0; i < list.size(); ++i)
  {
    const std::string where = "cameras[" + std::to_string(i) + "]";
    auto entry = readCameraEntry(list[i], where);
    if (!entry)
      return entry.error();
    const std::string& name = entry->camera.name;
    if (!names.insert(name).second)
      return Error(ErrorCode::kInvalidInput, where + ": the name '" + name + "' is used twice");
    // Two latched publishers on one topic would hand subscribers either camera's calibration.
    if (const auto [it, inserted] = info_topics.emplace(entry->calibrated_info_topic, name); !inserted)
      return Error(ErrorCode::kInvalidInput, where + ": cameras '" + it->second + "' and '" + name +
                                                 "' would both publish their CameraInfo on " +
                                                 entry->calibrated_info_topic + "; set calibrated_info_topic for one");
    out.push_back(std::move(*entry));
  }
  return out;
}
}  // namespace

Expected<std::vector<CameraConfigEntry>> loadCameraConfig(const std::string& path)
{
  const auto text = readFile(path);
  if (!text)
    return text.error();
  auto config = parseCameraConfig(*text);
  if (!config)
    return Error(config.error().code(), path + ": " + config.error().message());
  return config;
}

}  // namespace insitu_calibration
