// The directory of saved calibrations that calibration_node reloads at start-up and calibrate_survey writes:
// <dir>/<camera>.yaml (calibration_file.h) and <dir>/<camera>_overlay.png (for people). A restart must lose nothing
// and keep nothing broken: writes are atomic, what a killed write left behind is removed, a file that does not
// validate is renamed aside (never overwritten, never deleted) and the camera starts uncalibrated.
#ifndef INSITU_CALIBRATION_IO_CALIBRATION_STORE_H
#define INSITU_CALIBRATION_IO_CALIBRATION_STORE_H

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "insitu_calibration/error.h"
#include "insitu_calibration/io/calibration_file.h"

namespace insitu_calibration
{
class CalibrationStore
{
public:
  explicit CalibrationStore(std::string directory) : directory_(std::move(directory)) {}

  const std::string& directory() const { return directory_; }
  std::string calibrationPath(const std::string& camera) const;
  std::string overlayPath(const std::string& camera) const;

  // Removes the temporary files of a write that was killed before its rename: <camera>.yaml.tmp.XXXXXX,
  // <camera>_overlay.png.tmp.XXXXXX and the older .<camera>_overlay.tmp.png. Only these names of the cameras given
  // are touched. Returns the paths removed.
  std::vector<std::string> removeStaleTemporaries(const std::vector<std::string>& cameras) const;

  struct Loaded
  {
    std::optional<CalibrationFile> calibration;  // absent: no file, or a file that was not used
    std::string problem;                         // why a file present was not used (empty when used or absent)
    std::string set_aside_as;                    // where an invalid file was moved (empty when it was not)
  };
  // Reads and validates the camera's file. An unreadable or invalid one is renamed to <camera>.yaml.bad (then
  // .bad.1, .bad.2, ...: an earlier one is never overwritten); one for another image size is left in place.
  Loaded load(const std::string& camera, int image_width, int image_height) const;

  // Validates, then writes the calibration atomically, and the overlay when it is not empty. An empty overlay (the
  // image it is drawn on is gone after a restart) keeps the PNG already there instead of replacing it by a blank.
  Status save(const std::string& camera, const CalibrationFile& calibration, const cv::Mat& overlay) const;

private:
  std::string setAside(const std::string& path) const;

  std::string directory_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_IO_CALIBRATION_STORE_H
