#include "insitu_calibration/survey/survey_hint_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "../io/yaml_util.h"
#include "insitu_calibration/io/atomic_file.h"

namespace insitu_calibration
{
namespace
{
constexpr size_t kMaxRegions = 64;
constexpr size_t kMaxPolygonPoints = 10000;

std::string pair(const Eigen::Vector2d& v, const char* format)
{
  char buffer[96];
  std::snprintf(buffer, sizeof(buffer), format, v.x(), v.y());
  return buffer;
}

// A YAML double-quoted scalar (the region's place is a few plain words, but a name could hold anything).
std::string quoted(const std::string& text)
{
  std::string out = "\"";
  for (const char c : text)
  {
    if (c == '"' || c == '\\')
      out += '\\';
    out += c;
  }
  return out + "\"";
}

Expected<SurveyHintRegion> readRegion(const yaml_util::YamlNode& node, const std::string& where)
{
  using namespace yaml_util;
  if (!node || !node.IsMap())
    return Error(ErrorCode::kParseError, where + ": expected a map");
  SurveyHintRegion region;
  if (const YamlNode place = child(node, "where"); place && place.IsScalar())
    region.where = place.Scalar();
  const auto lines = toInt(child(node, "image_lines"), where + ".image_lines");
  const auto stand = toVector<2>(child(node, "standpoint"), where + ".standpoint");
  const auto look = toVector<2>(child(node, "look_direction"), where + ".look_direction");
  if (!lines || !stand || !look)
    return !lines ? lines.error() : (!stand ? stand.error() : look.error());
  if (*lines < 0)
    return Error(ErrorCode::kInvalidInput, where + ".image_lines: negative");
  if (look->norm() < 1e-9)
    return Error(ErrorCode::kInvalidInput, where + ".look_direction: zero length, not a direction");
  region.image_lines = static_cast<size_t>(*lines);
  region.standpoint = *stand;
  region.look_direction = look->normalized();
  const YamlNode polygon = child(node, "floor_polygon");
  if (polygon && !polygon.IsSequence())
    return Error(ErrorCode::kParseError, where + ".floor_polygon: expected a list of [x, y]");
  const size_t points = polygon ? polygon.size() : 0;
  if (const Status s = checkCount(points, kMaxPolygonPoints, where, "floor polygon points"); !s)
    return s.error();
  for (size_t k = 0; k < points; ++k)
  {
    const auto p = toVector<2>(polygon[k], where + ".floor_polygon[" + std::to_string(k) + "]");
    if (!p)
      return p.error();
    region.floor_polygon.push_back(*p);
  }
  if (const YamlNode share = child(node, "xtion_share"))
  {
    const auto value = toDouble(share, where + ".xtion_share");
    const auto heights = toVector<2>(child(node, "structure_height_m"), where + ".structure_height_m");
    if (!value || !heights)
      return !value ? value.error() : heights.error();
    if (*value < 0.0 || *value > 1.0)
      return Error(ErrorCode::kInvalidInput, where + ".xtion_share: not a share between 0 and 1");
    region.xtion_share = *value;
    region.structure_height_m = *heights;
  }
  if (const YamlNode pitch = child(node, "xtion_pitch_deg"))
  {
    const auto value = toDouble(pitch, where + ".xtion_pitch_deg");
    if (!value)
      return value.error();
    if (std::abs(*value) > 90.0)
      return Error(ErrorCode::kInvalidInput, where + ".xtion_pitch_deg: not a pitch between -90 and 90 deg");
    region.xtion_pitch_deg = *value;
  }
  if (const YamlNode height = child(node, "xtion_height_m"))
  {
    const auto value = toDouble(height, where + ".xtion_height_m");
    if (!value)
      return value.error();
    if (!region.xtion_pitch_deg || *value <= 0.0 || *value > 10.0)
      return Error(ErrorCode::kInvalidInput,
                   where + ".xtion_height_m: not a height between 0 and 10 m with an xtion_pitch_deg beside it");
    region.xtion_height_m = *value;
  }
  return region;
}
}  // namespace

SurveyHint surveyHintOf(const std::string& camera, const SurveyGuidance& guidance)
{
  SurveyHint hint;
  hint.camera = camera;
  hint.image_width = guidance.width;
  hint.image_height = guidance.height;
  for (const UnmappedRegion& r : guidance.regions)
  {
    // Out of the Xtion's reach: the mount its sentence advises (the height only where it changes).
    const std::optional<XtionMount> mount =
        r.outOfXtionReach(guidance.min_xtion_share) ? r.mountToSee() : std::optional<XtionMount>();
    std::optional<double> pitch, height;
    if (mount)
      pitch = mount->pitch_deg;
    if (mount && mount->new_height)
      height = mount->height_m;
    hint.regions.push_back({r.where, r.image_lines, r.robot_position, r.look_direction, r.floor_polygon, r.xtion_share,
                            Eigen::Vector2d(r.structure_min_height_m, r.structure_max_height_m), pitch, height});
  }
  return hint;
}

std::string surveyHintYaml(const SurveyHint& hint)
{
  std::ostringstream out;
  out << "# What to survey so that camera " << hint.camera
      << " can be calibrated (calibrate_survey): per region of its view without map lines, where the robot should "
         "stand and look. Map frame, metres.\n";
  out << "camera: " << quoted(hint.camera) << "\nframe: map\nimage_width: " << hint.image_width
      << "\nimage_height: " << hint.image_height << "\nregions:" << (hint.regions.empty() ? " []\n" : "\n");
  for (const SurveyHintRegion& r : hint.regions)
  {
    out << "  - where: " << quoted(r.where) << "\n    image_lines: " << r.image_lines
        << "\n    standpoint: " << pair(r.standpoint, "[%.3f, %.3f]")
        << "\n    look_direction: " << pair(r.look_direction, "[%.4f, %.4f]") << "\n    floor_polygon: [";
    for (size_t k = 0; k < r.floor_polygon.size(); ++k)
      out << (k ? ", " : "") << pair(r.floor_polygon[k], "[%.3f, %.3f]");
    out << "]\n";
    if (r.xtion_share >= 0.0)
    {
      char share[32];
      std::snprintf(share, sizeof(share), "%.2f", r.xtion_share);
      out << "    structure_height_m: " << pair(r.structure_height_m, "[%.2f, %.2f]") << "\n    xtion_share: " << share
          << "\n";
    }
    if (r.xtion_pitch_deg)
    {
      char pitch[32];
      std::snprintf(pitch, sizeof(pitch), "%.0f", *r.xtion_pitch_deg);
      out << "    xtion_pitch_deg: " << pitch << "\n";
    }
    if (r.xtion_height_m)
    {
      char height[32];
      std::snprintf(height, sizeof(height), "%.2f", *r.xtion_height_m);
      out << "    xtion_height_m: " << height << "\n";
    }
  }
  return out.str();
}

Expected<SurveyHint> parseSurveyHint(const std::string& yaml_text, const std::string& source)
{
  using namespace yaml_util;
  const auto tree = parseYaml(yaml_text, source);
  if (!tree)
    return tree.error();
  return guarded<SurveyHint>(source, [&]() -> Expected<SurveyHint> {
    const YamlNode doc = tree->root();
    if (!doc || !doc.IsMap())
      return Error(ErrorCode::kParseError, source + ": expected a map with camera and regions");
    SurveyHint hint;
    if (const YamlNode name = child(doc, "camera"); name && name.IsScalar())
      hint.camera = name.Scalar();
    for (const auto& [key, value] : {std::pair{"image_width", &hint.image_width}, {"image_height", &hint.image_height}})
      if (child(doc, key))
      {
        const auto n = toInt(child(doc, key), source + ": " + key);
        if (!n)
          return n.error();
        *value = *n;
      }
    const YamlNode regions = child(doc, "regions");
    if (!regions || !regions.IsSequence())
      return Error(ErrorCode::kParseError, source + ": expected a list `regions:`");
    if (const Status s = checkCount(regions.size(), kMaxRegions, source, "regions"); !s)
      return s.error();
    for (size_t k = 0; k < regions.size(); ++k)
    {
      auto region = readRegion(regions[k], source + ": regions[" + std::to_string(k) + "]");
      if (!region)
        return region.error();
      hint.regions.push_back(std::move(*region));
    }
    return hint;
  });
}

Expected<SurveyHint> readSurveyHint(const std::string& path)
{
  const auto text = readFile(path);
  if (!text)
    return text.error();
  return parseSurveyHint(*text, path);
}

std::optional<AdvisedMount> advisedXtionMount(const std::vector<SurveyHint>& hints)
{
  std::vector<const SurveyHintRegion*> advising;
  for (const SurveyHint& hint : hints)
    for (const SurveyHintRegion& region : hint.regions)
      if (region.xtion_pitch_deg)
        advising.push_back(&region);
  const auto sameMount = [](const SurveyHintRegion& a, const SurveyHintRegion& b) {
    const double height_a = a.xtion_height_m.value_or(-1.0), height_b = b.xtion_height_m.value_or(-1.0);
    return std::abs(*a.xtion_pitch_deg - *b.xtion_pitch_deg) <= kSameMountPitchDeg &&
           std::abs(height_a - height_b) < 0.05;
  };
  const SurveyHintRegion* chosen = nullptr;
  size_t most = 0;
  for (const SurveyHintRegion* candidate : advising)
  {
    size_t served = 0;
    for (const SurveyHintRegion* region : advising)
      served += sameMount(*candidate, *region) ? std::max<size_t>(region->image_lines, 1) : 0;
    if (served > most)
      chosen = candidate, most = served;
  }
  if (!chosen)
    return std::nullopt;
  return AdvisedMount{*chosen->xtion_pitch_deg, chosen->xtion_height_m};
}

}  // namespace insitu_calibration
