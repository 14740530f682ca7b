#include "insitu_calibration/io/correspondence_file.h"

#include "insitu_calibration/io/atomic_file.h"
#include "yaml_util.h"

namespace insitu_calibration
{
namespace
{
template <int N>
Expected<std::vector<Eigen::Matrix<double, N, 1>>> toPointList(const yaml_util::YamlNode& node,
                                                               const std::string& where)
{
  if (!node || !node.IsSequence())
    return Error(ErrorCode::kParseError, where + ": expected a list of [" + (N == 2 ? "u, v" : "x, y, z") + "]");
  if (const Status s = yaml_util::checkCount(node.size(), correspondence_limits::kMaxPointsPerLine, where, "points");
      !s)
    return s.error();
  std::vector<Eigen::Matrix<double, N, 1>> out;
  for (size_t i = 0; i < node.size(); ++i)
  {
    const auto v = yaml_util::toVector<N>(node[i], where + "[" + std::to_string(i) + "]");
    if (!v)
      return v.error();
    out.push_back(*v);
  }
  return out;
}

// Ranges beyond which a value is a mistake, not a measurement: pixels far outside the image (they would also push
// the eigen-solvers out of double range) and world coordinates beyond any building.
Status checkRanges(const CorrespondenceSet& set)
{
  using namespace correspondence_limits;
  if (set.image_width > kMaxImageSide || set.image_height > kMaxImageSide)
    return Error(ErrorCode::kInvalidInput,
                 "image_width and image_height may be at most " + std::to_string(kMaxImageSide) + " (got " +
                     std::to_string(set.image_width) + " x " + std::to_string(set.image_height) + ")");
  const Eigen::Vector2d size(set.image_width, set.image_height);
  const auto pixel_ok = [&](const Eigen::Vector2d& p) {
    return (p.array() >= -kImageMargin * size.array()).all() &&
           (p.array() <= (1.0 + kImageMargin) * size.array()).all();
  };
  const auto world_ok = [](const Eigen::Vector3d& x) { return x.allFinite() && x.cwiseAbs().maxCoeff() <= kMaxWorldM; };
  const std::string pixel_rule = ": an image point lies more than one image size outside the image";
  const std::string world_rule = ": a world point is beyond " + std::to_string(static_cast<int>(kMaxWorldM)) + " m";
  for (size_t i = 0; i < set.lines.size(); ++i)
  {
    const std::string where = "lines[" + std::to_string(i) + "]";
    for (const auto& p : set.lines[i].image)
      if (!pixel_ok(p))
        return Error(ErrorCode::kInvalidInput, where + pixel_rule);
    for (const auto& x : set.lines[i].world)
      if (!world_ok(x))
        return Error(ErrorCode::kInvalidInput, where + world_rule);
  }
  for (size_t i = 0; i < set.points.size(); ++i)
    if (!pixel_ok(set.points[i].image) || !world_ok(set.points[i].world))
      return Error(ErrorCode::kInvalidInput,
                   "points[" + std::to_string(i) + "]" + pixel_rule + " or" + world_rule.substr(1));
  return Success{};
}

// The optional `lines` list; an absent or null list leaves `lines` empty.
Status parseLineList(const yaml_util::YamlNode& lines, std::vector<LineCorrespondence>& out)
{
  if (!lines || lines.IsNull())
    return Success{};
  if (!lines.IsSequence())
    return Error(ErrorCode::kParseError, "lines: expected a list");
  if (const Status s = yaml_util::checkCount(lines.size(), correspondence_limits::kMaxLines, "lines", "lines"); !s)
    return s.error();
  for (size_t i = 0; i < lines.size(); ++i)
  {
    const std::string where = "lines[" + std::to_string(i) + "]";
    if (!lines[i].IsMap())
      return Error(ErrorCode::kParseError, where + ": expected a map with image and world");
    LineCorrespondence line;
    auto image = toPointList<2>(lines[i]["image"], where + ".image");
    if (!image)
      return image.error();
    auto world = toPointList<3>(lines[i]["world"], where + ".world");
    if (!world)
      return world.error();
    line.image = std::move(*image);
    line.world = std::move(*world);
    // Optional: the noise of this line's world points, m per axis (0: exact, a BIM model's line).
    if (const yaml_util::YamlNode sigma = lines[i]["world_sigma"]; sigma)
    {
      const auto value = yaml_util::toDouble(sigma, where + ".world_sigma");
      if (!value)
        return value.error();
      if (!(*value >= 0.0))
        return Error(ErrorCode::kInvalidInput, where + ".world_sigma: must be 0 or positive (m)");
      line.world_point_sigma_m = *value;
    }
    out.push_back(std::move(line));
  }
  return Success{};
}

// The optional `points` list; an absent or null list leaves `points` empty.
Status parsePointList(const yaml_util::YamlNode& points, std::vector<PointCorrespondence>& out)
{
  if (!points || points.IsNull())
    return Success{};
  if (!points.IsSequence())
    return Error(ErrorCode::kParseError, "points: expected a list");
  if (const Status s = yaml_util::checkCount(points.size(), correspondence_limits::kMaxPoints, "points", "points"); !s)
    return s.error();
  for (size_t i = 0; i < points.size(); ++i)
  {
    const std::string where = "points[" + std::to_string(i) + "]";
    if (!points[i].IsMap())
      return Error(ErrorCode::kParseError, where + ": expected a map with image and world");
    const auto image = yaml_util::toVector<2>(points[i]["image"], where + ".image");
    if (!image)
      return image.error();
    const auto world = yaml_util::toVector<3>(points[i]["world"], where + ".world");
    if (!world)
      return world.error();
    out.push_back({*image, *world});
  }
  return Success{};
}

Expected<CorrespondenceSet> parseDocument(const std::string& yaml_text)
{
  const auto root = yaml_util::parseYaml(yaml_text, "correspondence file");
  if (!root)
    return root.error();
  const yaml_util::YamlNode doc = root->root();
  if (!doc.IsMap())
    return Error(ErrorCode::kParseError, "correspondence file: expected a map with image_width, image_height, lines");
  CorrespondenceSet set;
  if (doc["camera_name"])
    set.camera_name = doc["camera_name"].IsScalar() ? doc["camera_name"].Scalar() : "";
  const auto width = yaml_util::toInt(doc["image_width"], "image_width");
  if (!width)
    return width.error();
  const auto height = yaml_util::toInt(doc["image_height"], "image_height");
  if (!height)
    return height.error();
  set.image_width = *width;
  set.image_height = *height;
  if (!doc["lines"] && !doc["points"])
    return Error(ErrorCode::kParseError, "correspondence file: neither 'lines' nor 'points' is present");
  if (const Status lines = parseLineList(doc["lines"], set.lines); !lines)
    return lines.error();
  if (const Status points = parsePointList(doc["points"], set.points); !points)
    return points.error();
  if (const Status valid = set.validate(); !valid)
    return valid.error();
  if (const Status in_range = checkRanges(set); !in_range)
    return in_range.error();
  return set;
}
}  // namespace

Expected<CorrespondenceSet> parseCorrespondences(const std::string& yaml_text)
{
  return yaml_util::guarded<CorrespondenceSet>("correspondence file", [&] { return parseDocument(yaml_text); });
}

Expected<CorrespondenceSet> loadCorrespondenceFile(const std::string& path)
{
  const auto text = readFile(path);
  if (!text)
    return text.error();
  auto set = parseCorrespondences(*text);
  if (!set)
    return Error(set.error().code(), path + ": " + set.error().message());
  return set;
}

std::string formatCorrespondences(const CorrespondenceSet& data)
{
  YAML::Emitter out;
  out.SetDoublePrecision(12);
  out << YAML::BeginMap;
  if (!data.camera_name.empty())
    out << YAML::Key << "camera_name" << YAML::Value << data.camera_name;
  out << YAML::Key << "image_width" << YAML::Value << data.image_width;
  out << YAML::Key << "image_height" << YAML::Value << data.image_height;
  out << YAML::Key << "lines" << YAML::Value << YAML::BeginSeq;
  for (const auto& line : data.lines)
  {
    out << YAML::BeginMap << YAML::Key << "image" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const auto& p : line.image)
      yaml_util::emitVector(out, p);
    out << YAML::EndSeq << YAML::Key << "world" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const auto& p : line.world)
      yaml_util::emitVector(out, p);
    out << YAML::EndSeq;
    if (line.world_point_sigma_m >= 0.0)
      out << YAML::Key << "world_sigma" << YAML::Value << line.world_point_sigma_m;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!data.points.empty())
  {
    out << YAML::Key << "points" << YAML::Value << YAML::BeginSeq;
    for (const auto& p : data.points)
    {
      out << YAML::BeginMap << YAML::Key << "image" << YAML::Value;
      yaml_util::emitVector(out, p.image);
      out << YAML::Key << "world" << YAML::Value;
      yaml_util::emitVector(out, p.world);
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

Status saveCorrespondenceFile(const std::string& path, const CorrespondenceSet& data)
{
  return writeFileAtomically(path, formatCorrespondences(data));
}

}  // namespace insitu_calibration
