#include "insitu_calibration/io/calibration_file.h"

#include <cmath>

#include <Eigen/Geometry>

#include "insitu_calibration/io/atomic_file.h"
#include "yaml_util.h"

namespace insitu_calibration
{
std::string formatCalibration(const CalibrationFile& c)
{
  const Intrinsics& in = c.camera.intrinsics();
  const Eigen::Matrix3d k = in.matrix();
  PlumbBobFit plumb_bob = c.plumb_bob;
  if (c.camera.distortion().lambda != 0.0 && plumb_bob.max_error_px == 0.0 && plumb_bob.coefficients[0] == 0.0)
    plumb_bob = fitPlumbBob(in, c.camera.distortion(), c.image_width, c.image_height);
  Matrix34d rectified_projection = Matrix34d::Zero();
  rectified_projection.leftCols<3>() = k;

  YAML::Emitter out;
  out.SetDoublePrecision(15);
  out << YAML::BeginMap;
  out << YAML::Key << "image_width" << YAML::Value << c.image_width;
  out << YAML::Key << "image_height" << YAML::Value << c.image_height;
  out << YAML::Key << "camera_name" << YAML::Value << c.camera_name;
  yaml_util::emitMatrix(out, "camera_matrix", k);
  out << YAML::Key << "distortion_model" << YAML::Value << "plumb_bob";
  yaml_util::emitMatrix(
      out, "distortion_coefficients",
      Eigen::Matrix<double, 1, 5>(Eigen::Map<const Eigen::Matrix<double, 1, 5>>(plumb_bob.coefficients.data())));
  yaml_util::emitMatrix(out, "rectification_matrix", Eigen::Matrix3d::Identity());
  yaml_util::emitMatrix(out, "projection_matrix", rectified_projection);

  out << YAML::Key << "division_model" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "lambda" << YAML::Value << c.camera.distortion().lambda;
  out << YAML::Key << "center" << YAML::Value;
  yaml_util::emitVector(out, c.camera.distortion().center);
  out << YAML::Key << "plumb_bob_max_error_px" << YAML::Value << plumb_bob.max_error_px;
  out << YAML::EndMap;

  yaml_util::emitMatrix(out, "world_projection_matrix", c.camera.projectionMatrix());

  const Eigen::Isometry3d world_from_camera = c.camera.pose().worldFromCamera();
  const Eigen::Quaterniond q(world_from_camera.linear());
  out << YAML::Key << "camera_pose" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "frame_id" << YAML::Value << c.world_frame;
  out << YAML::Key << "position" << YAML::Value;
  yaml_util::emitVector(out, Eigen::Vector3d(world_from_camera.translation()));
  out << YAML::Key << "orientation" << YAML::Value;
  yaml_util::emitVector(out, Eigen::Vector4d(q.x(), q.y(), q.z(), q.w()));
  out << YAML::EndMap;

  if (c.quality)
  {
    const CalibrationQuality& q = *c.quality;
    out << YAML::Key << "quality" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "rms_px" << YAML::Value << q.rms_px;
    out << YAML::Key << "median_px" << YAML::Value << q.median_px;
    out << YAML::Key << "lines" << YAML::Value << q.lines;
    out << YAML::Key << "points" << YAML::Value << q.points;
    out << YAML::Key << "constraints" << YAML::Value << q.constraints;
    out << YAML::Key << "distortion_estimated" << YAML::Value << q.distortion_estimated;
    for (const auto& [key, value] : q.extra)
      out << YAML::Key << key << YAML::Value << value;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

Status saveCalibrationFile(const std::string& path, const CalibrationFile& calibration)
{
  return writeFileAtomically(path, formatCalibration(calibration));
}

namespace
{
constexpr int kMaxImageSide = 32768;

bool finite(double value)
{
  return std::isfinite(value);
}

Status checkImageGeometry(const CalibrationFile& c)
{
  if (c.image_width < 1 || c.image_height < 1 || c.image_width > kMaxImageSide || c.image_height > kMaxImageSide)
    return Error(ErrorCode::kInvalidInput,
                 "image_width x image_height must be within 1.." + std::to_string(kMaxImageSide) + " (got " +
                     std::to_string(c.image_width) + " x " + std::to_string(c.image_height) + ")");
  const Intrinsics& in = c.camera.intrinsics();
  const Eigen::Vector2d size(c.image_width, c.image_height);
  const auto near_image = [&](const Eigen::Vector2d& p) {
    return p.allFinite() && (p.array() >= -size.array()).all() && (p.array() <= 2.0 * size.array()).all();
  };
  if (!(in.fx > 0.0 && in.fy > 0.0 && in.fx < 1e3 * size.maxCoeff() && in.fy < 1e3 * size.maxCoeff()))
    return Error(ErrorCode::kInvalidInput, "camera_matrix: the focal lengths must be positive and finite (got fx " +
                                               std::to_string(in.fx) + ", fy " + std::to_string(in.fy) + ")");
  if (!finite(in.skew) || std::abs(in.skew) > in.fx || !near_image(in.principalPoint()))
    return Error(ErrorCode::kInvalidInput,
                 "camera_matrix: the skew must be below fx and the principal point within one image size of the "
                 "image");
  const DivisionModel& d = c.camera.distortion();
  if (!finite(d.lambda) || !near_image(d.center))
    return Error(ErrorCode::kInvalidInput,
                 "division_model: lambda must be finite and the centre within one image size of the image");
  double r2 = 0.0;  // the largest squared radius of a pixel of the image about the distortion centre
  for (const double u : {-0.5, c.image_width - 0.5})
    for (const double v : {-0.5, c.image_height - 0.5})
      r2 = std::max(r2, (Eigen::Vector2d(u, v) - d.center).squaredNorm());
  if (!(std::abs(d.lambda) * r2 < 1.0))
    return Error(ErrorCode::kInvalidInput,
                 "division_model.lambda " + std::to_string(d.lambda) + " folds the image (|lambda| r^2 = " +
                     std::to_string(std::abs(d.lambda) * r2) + " at a corner, it must stay below 1)");
  return Success{};
}
}  // namespace

Status validateCalibration(const CalibrationFile& c)
{
  if (const Status geometry = checkImageGeometry(c); !geometry)
    return geometry;
  const Eigen::Isometry3d world_from_camera = c.camera.pose().worldFromCamera();
  if (!world_from_camera.matrix().allFinite())
    return Error(ErrorCode::kInvalidInput, "camera_pose: NaN or infinite values");
  for (const double k : c.plumb_bob.coefficients)
    if (!finite(k))
      return Error(ErrorCode::kInvalidInput, "distortion_coefficients: NaN or infinite values");
  if (!finite(c.plumb_bob.max_error_px) || c.plumb_bob.max_error_px < 0.0)
    return Error(ErrorCode::kInvalidInput, "division_model.plumb_bob_max_error_px must be finite and >= 0");
  if (c.quality)
  {
    if (!(finite(c.quality->rms_px) && finite(c.quality->median_px) && c.quality->rms_px >= 0.0 &&
          c.quality->median_px >= 0.0))
      return Error(ErrorCode::kInvalidInput, "quality: NaN, infinite or negative values");
  }
  return Success{};
}

namespace
{
// division_model: {lambda, center, plumb_bob_max_error_px}; without it, no distortion about the principal point.
Status readDivisionModel(const yaml_util::YamlNode& doc, CalibrationFile& c)
{
  const yaml_util::YamlNode division = doc["division_model"];
  if (!division)
  {
    c.camera.distortion() = DivisionModel{0.0, c.camera.intrinsics().principalPoint()};
    return Success{};
  }
  if (!division.IsMap())
    return Error(ErrorCode::kParseError, "division_model: expected a map {lambda, center}");
  const auto lambda = yaml_util::toDouble(division["lambda"], "division_model.lambda");
  if (!lambda)
    return lambda.error();
  const auto center = yaml_util::toVector<2>(division["center"], "division_model.center");
  if (!center)
    return center.error();
  c.camera.distortion() = DivisionModel{*lambda, *center};
  if (division["plumb_bob_max_error_px"])
  {
    const auto max_error =
        yaml_util::toDouble(division["plumb_bob_max_error_px"], "division_model.plumb_bob_max_error_px");
    if (!max_error)
      return max_error.error();
    c.plumb_bob.max_error_px = *max_error;
  }
  return Success{};
}

// The plumb_bob approximation ROS tools read (optional: it is recomputed on saving).
Status readPlumbBob(const yaml_util::YamlNode& doc, CalibrationFile& c)
{
  const yaml_util::YamlNode d = yaml_util::child(doc, "distortion_coefficients");
  if (!(d && d["data"] && d["data"].IsSequence()))
    return Success{};
  if (d["data"].size() > 16)
    return Error(ErrorCode::kParseError, "distortion_coefficients.data: expected at most 16 numbers");
  const auto coefficients = yaml_util::toNumbers(d["data"], "distortion_coefficients.data");
  if (!coefficients)
    return coefficients.error();
  for (size_t i = 0; i < std::min<size_t>(5, coefficients->size()); ++i)
    c.plumb_bob.coefficients[i] = (*coefficients)[i];
  return Success{};
}

Status readCameraPose(const yaml_util::YamlNode& doc, CalibrationFile& c)
{
  const yaml_util::YamlNode pose = doc["camera_pose"];
  if (!pose || !pose.IsMap())
    return Error(ErrorCode::kParseError, "camera_pose: missing (this file has intrinsics but no pose in the world)");
  c.world_frame = pose["frame_id"] && pose["frame_id"].IsScalar() ? pose["frame_id"].Scalar() : "map";
  const auto position = yaml_util::toVector<3>(pose["position"], "camera_pose.position");
  if (!position)
    return position.error();
  const auto orientation = yaml_util::toVector<4>(pose["orientation"], "camera_pose.orientation");
  if (!orientation)
    return orientation.error();
  const Eigen::Quaterniond q((*orientation)(3), (*orientation)(0), (*orientation)(1), (*orientation)(2));
  if (!(q.norm() > 1e-9))
    return Error(ErrorCode::kInvalidInput, "camera_pose.orientation: zero quaternion");
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() = q.normalized().toRotationMatrix();
  world_from_camera.translation() = *position;
  c.camera.pose() = CameraPose::fromWorldFromCamera(world_from_camera);
  return Success{};
}

// One entry of quality: the named fields, and any other finite number as an extra (non-numeric notes are dropped).
void readQualityEntry(const std::string& key, const yaml_util::YamlNode& value, CalibrationQuality& q)
{
  if (key == "rms_px")
    q.rms_px = value.as<double>(0.0);
  else if (key == "median_px")
    q.median_px = value.as<double>(0.0);
  else if (key == "lines")
    q.lines = value.as<size_t>(0);
  else if (key == "points")
    q.points = value.as<size_t>(0);
  else if (key == "constraints")
    q.constraints = value.as<size_t>(0);
  else if (key == "distortion_estimated")
    q.distortion_estimated = value.as<bool>(false);
  else if (value.IsScalar())
  {
    try
    {
      if (const double number = value.as<double>(); std::isfinite(number))
        q.extra[key] = number;
    }
    catch (const YAML::Exception&)
    {}
  }
}

Status readQuality(const yaml_util::YamlNode& doc, CalibrationFile& c)
{
  const yaml_util::YamlNode quality = doc["quality"];
  if (!(quality && quality.IsMap()))
    return Success{};
  CalibrationQuality q;
  for (const auto& kv : quality)
  {
    if (!kv.first.IsScalar())
      return Error(ErrorCode::kParseError, "quality: a key is not a name");
    readQualityEntry(kv.first.Scalar(), kv.second, q);
  }
  c.quality = q;
  return Success{};
}

Expected<CalibrationFile> parseDocument(const std::string& yaml_text)
{
  const auto root = yaml_util::parseYaml(yaml_text, "calibration file");
  if (!root)
    return root.error();
  const yaml_util::YamlNode doc = root->root();
  if (!doc.IsMap())
    return Error(ErrorCode::kParseError, "calibration file: expected a map");
  CalibrationFile c;
  c.camera_name = doc["camera_name"] && doc["camera_name"].IsScalar() ? doc["camera_name"].Scalar() : "";
  const auto width = yaml_util::toInt(doc["image_width"], "image_width");
  const auto height = yaml_util::toInt(doc["image_height"], "image_height");
  if (!width || !height)
    return !width ? width.error() : height.error();
  c.image_width = *width;
  c.image_height = *height;
  const auto k = yaml_util::toMatrix<3, 3>(doc["camera_matrix"], "camera_matrix");
  if (!k)
    return k.error();
  c.camera.intrinsics() = Intrinsics::fromMatrix(*k);
  for (const auto read : {readDivisionModel, readPlumbBob, readCameraPose, readQuality})
    if (const Status s = read(doc, c); !s)
      return s.error();
  if (const Status valid = validateCalibration(c); !valid)
    return valid.error();
  return c;
}
}  // namespace

Expected<CalibrationFile> parseCalibration(const std::string& yaml_text)
{
  return yaml_util::guarded<CalibrationFile>("calibration file", [&] { return parseDocument(yaml_text); });
}

Expected<CalibrationFile> loadCalibrationFile(const std::string& path)
{
  const auto text = readFile(path);
  if (!text)
    return text.error();
  auto c = parseCalibration(*text);
  if (!c)
    return Error(c.error().code(), path + ": " + c.error().message());
  return c;
}

}  // namespace insitu_calibration
