#include "insitu_calibration/io/calibration_store.h"

#include <cctype>
#include <filesystem>

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
      const bool stale = isTemporaryOf(name, camera + ".yaml.tmp.") ||
                         isTemporaryOf(name, camera + "_overlay.png.tmp.") || name == "." + camera + "_overlay.tmp.png";
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

Status CalibrationStore::save(const std::string& camera, const CalibrationFile& calibration,
                              const cv::Mat& overlay) const
{
  if (const Status valid = validateCalibration(calibration); !valid)
    return Error(valid.error().code(), "not saving the calibration of '" + camera + "': " + valid.error().message());
  if (const Status saved = saveCalibrationFile(calibrationPath(camera), calibration); !saved)
    return saved;
  if (overlay.empty())
    return Success{};
  std::vector<unsigned char> png;
  try
  {
    if (!cv::imencode(".png", overlay, png))
      return Error(ErrorCode::kIoError, "cannot encode the overlay of '" + camera + "' as PNG");
  }
  catch (const cv::Exception& e)
  {
    return Error(ErrorCode::kIoError, "cannot encode the overlay of '" + camera + "' as PNG: " + e.what());
  }
  return writeFileAtomically(overlayPath(camera), std::string(png.begin(), png.end()));
}

}  // namespace insitu_calibration
