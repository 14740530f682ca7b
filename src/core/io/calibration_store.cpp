#include "insitu_calibration/io/calibration_store.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "insitu_calibration/io/atomic_file.h"

namespace insitu_calibration
{
namespace fs = std::filesystem;

namespace
{
// "<prefix>XXXXXX" with six characters from mkstemp's alphabet after the prefix.
bool isTemporaryOf(const std::string& file_name, const std::string& prefix)
{
  if (file_name.size() != prefix.size() + 6 || file_name.compare(0, prefix.size(), prefix) != 0)
    return false;
  for (size_t i = prefix.size(); i < file_name.size(); ++i)
    if (!std::isalnum(static_cast<unsigned char>(file_name[i])))
      return false;
  return true;
}

std::string readWhole(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Whether a saved file holds this calibration's camera (to the digits a file keeps: a file read and written again
// differs from the first write in the last ones). The quality block may differ (sigmas widened afterwards).
bool sameCalibration(const std::string& saved_text, const CalibrationFile& calibration)
{
  const auto saved = parseCalibration(saved_text);
  if (!saved || saved->camera_name != calibration.camera_name || saved->image_width != calibration.image_width ||
      saved->image_height != calibration.image_height || saved->world_frame != calibration.world_frame)
    return false;
  const CameraModel& a = saved->camera;
  const CameraModel& b = calibration.camera;
  const auto close = [](double x, double y) { return std::abs(x - y) <= 1e-9 * std::max(1.0, std::abs(x)); };
  const Intrinsics &ka = a.intrinsics(), &kb = b.intrinsics();
  bool same = close(ka.fx, kb.fx) && close(ka.fy, kb.fy) && close(ka.skew, kb.skew) && close(ka.cx, kb.cx) &&
              close(ka.cy, kb.cy) && std::abs(a.distortion().lambda - b.distortion().lambda) <= 1e-18 &&
              close(a.distortion().center.x(), b.distortion().center.x()) &&
              close(a.distortion().center.y(), b.distortion().center.y());
  for (int i = 0; i < 3; ++i)
  {
    same = same && close(a.pose().translation(i), b.pose().translation(i));
    for (int j = 0; j < 3; ++j)
      same = same && close(a.pose().rotation(i, j), b.pose().rotation(i, j));
  }
  return same;
}

// When a file was last written, as UTC "20261130T071100Z".
std::string utcWriteTime(const std::string& path)
{
  std::error_code ec;
  const auto written = fs::last_write_time(path, ec);
  const auto system = ec ? std::chrono::system_clock::now()
                         : std::chrono::time_point_cast<std::chrono::system_clock::duration>(
                               written - fs::file_time_type::clock::now() + std::chrono::system_clock::now());
  const std::time_t t = std::chrono::system_clock::to_time_t(system);
  std::tm utc{};
  gmtime_r(&t, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y%m%dT%H%M%SZ", &utc);
  return text;
}
Status writePngAtomically(const std::string& path, const cv::Mat& image, const std::string& what)
{
  std::vector<unsigned char> png;
  try
  {
    if (!cv::imencode(".png", image, png))
      return Error(ErrorCode::kIoError, "cannot encode " + what + " as PNG");
  }
  catch (const cv::Exception& e)
  {
    return Error(ErrorCode::kIoError, "cannot encode " + what + " as PNG: " + e.what());
  }
  return writeFileAtomically(path, std::string(png.begin(), png.end()));
}
}  // namespace

std::string CalibrationStore::calibrationPath(const std::string& camera) const
{
  return directory_ + "/" + camera + ".yaml";
}

std::string CalibrationStore::overlayPath(const std::string& camera) const
{
  return directory_ + "/" + camera + "_overlay.png";
}

std::vector<std::string> CalibrationStore::removeStaleTemporaries(const std::vector<std::string>& cameras) const
{
  std::vector<std::string> removed;
  std::error_code ec;
  for (fs::directory_iterator it(directory_, ec), end; !ec && it != end; it.increment(ec))
  {
    const std::string name = it->path().filename().string();
    for (const std::string& camera : cameras)
    {
      const size_t tmp = name.rfind(".tmp.");
      const bool report_temporary = name.rfind(camera + "_report", 0) == 0 && tmp != std::string::npos &&
                                    isTemporaryOf(name, name.substr(0, tmp + 5));
      const bool stale = isTemporaryOf(name, camera + ".yaml.tmp.") ||
                         isTemporaryOf(name, camera + "_overlay.png.tmp.") ||
                         isTemporaryOf(name, camera + "_survey_hint.png.tmp.") ||
                         isTemporaryOf(name, camera + "_survey_hint.yaml.tmp.") ||
                         name == "." + camera + "_overlay.tmp.png" || report_temporary;
      std::error_code ignored;
      if (stale && it->is_regular_file(ignored) && fs::remove(it->path(), ignored))
        removed.push_back(it->path().string());
    }
  }
  return removed;
}

std::string CalibrationStore::setAside(const std::string& path) const
{
  std::error_code ec;
  for (int n = 0; n < 1000; ++n)
  {
    const std::string target = path + ".bad" + (n == 0 ? "" : "." + std::to_string(n));
    if (fs::exists(target, ec) || fs::is_symlink(target, ec))
      continue;
    fs::rename(path, target, ec);
    return ec ? std::string() : target;
  }
  return {};
}

CalibrationStore::Loaded CalibrationStore::load(const std::string& camera, int image_width, int image_height) const
{
  Loaded loaded;
  const std::string path = calibrationPath(camera);
  std::error_code ec;
  if (!fs::exists(path, ec))
    return loaded;
  const auto file = loadCalibrationFile(path);
  if (!file)
  {
    loaded.problem = file.error().describe();
    loaded.set_aside_as = setAside(path);
    loaded.problem += loaded.set_aside_as.empty() ? " (could not rename it aside; it is left in place)"
                                                  : "; set aside as " + loaded.set_aside_as;
    return loaded;
  }
  if (file->image_width != image_width || file->image_height != image_height)
  {
    loaded.problem = path + " is for a " + std::to_string(file->image_width) + "x" +
                     std::to_string(file->image_height) + " image, the camera is configured " +
                     std::to_string(image_width) + "x" + std::to_string(image_height) + "; not used";
    return loaded;
  }
  loaded.calibration = *file;
  return loaded;
}

std::string CalibrationStore::archivedPath(const std::string& camera, const std::string& utc) const
{
  return directory_ + "/" + camera + "." + utc + ".yaml";
}

std::optional<CalibrationFile> CalibrationStore::saved(const std::string& camera) const
{
  std::error_code ec;
  if (!fs::exists(calibrationPath(camera), ec))
    return std::nullopt;
  auto file = loadCalibrationFile(calibrationPath(camera));
  return file ? std::optional<CalibrationFile>(*file) : std::nullopt;
}

Expected<std::string> CalibrationStore::keepPrevious(const std::string& camera,
                                                     const CalibrationFile& replacement) const
{
  const std::string path = calibrationPath(camera);
  std::error_code ec;
  if (!fs::exists(path, ec))
    return std::string();
  const std::string previous = readWhole(path);
  if (sameCalibration(previous, replacement))
    return std::string();  // the same calibration saved again: nothing to keep
  const std::string utc = utcWriteTime(path);
  std::string target = archivedPath(camera, utc);
  std::string overlay_target = directory_ + "/" + camera + "_overlay." + utc + ".png";
  for (int n = 1; fs::exists(target, ec) && n < 1000; ++n)
  {
    target = archivedPath(camera, utc + "." + std::to_string(n));
    overlay_target = directory_ + "/" + camera + "_overlay." + utc + "." + std::to_string(n) + ".png";
  }
  if (const Status written = writeFileAtomically(target, previous); !written)
    return Error(ErrorCode::kIoError, "not replacing the calibration of '" + camera +
                                          "': cannot keep the previous one: " + written.error().message());
  if (fs::exists(overlayPath(camera), ec))
    fs::copy_file(overlayPath(camera), overlay_target, ec);  // for people only: a failure loses no calibration
  return target;
}

Status CalibrationStore::save(const std::string& camera, const CalibrationFile& calibration, const cv::Mat& overlay,
                              std::string* kept_as) const
{
  if (const Status valid = validateCalibration(calibration); !valid)
    return Error(valid.error().code(), "not saving the calibration of '" + camera + "': " + valid.error().message());
  const auto kept = keepPrevious(camera, calibration);
  if (!kept)
    return kept.error();
  if (kept_as)
    *kept_as = *kept;
  if (const Status saved = saveCalibrationFile(calibrationPath(camera), calibration); !saved)
    return saved;
  // A survey hint describes a refusal this calibration supersedes.
  std::error_code ignored;
  fs::remove(surveyHintPath(camera), ignored);
  fs::remove(surveyHintYamlPath(camera), ignored);
  if (overlay.empty())
    return Success{};
  return writePngAtomically(overlayPath(camera), overlay, "the overlay of '" + camera + "'");
}

std::string CalibrationStore::surveyHintPath(const std::string& camera) const
{
  return directory_ + "/" + camera + "_survey_hint.png";
}

Status CalibrationStore::saveSurveyHint(const std::string& camera, const cv::Mat& hint) const
{
  if (hint.empty())
    return Error(ErrorCode::kInvalidInput, "no survey hint of '" + camera + "' to save");
  return writePngAtomically(surveyHintPath(camera), hint, "the survey hint of '" + camera + "'");
}

std::string CalibrationStore::surveyHintYamlPath(const std::string& camera) const
{
  return directory_ + "/" + camera + "_survey_hint.yaml";
}

Status CalibrationStore::saveSurveyHintYaml(const std::string& camera, const std::string& yaml_text) const
{
  if (const Status written = writeFileAtomically(surveyHintYamlPath(camera), yaml_text); !written)
    return Error(written.error().code(), "the survey hint of '" + camera + "': " + written.error().message());
  return Success{};
}

}  // namespace insitu_calibration
