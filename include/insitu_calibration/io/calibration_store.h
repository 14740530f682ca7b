// The directory of saved calibrations that calibration_node reloads at start-up and calibrate_survey writes:
// <dir>/<camera>.yaml (calibration_file.h), <dir>/<camera>_overlay.png (for people) and, after a refusal,
// <dir>/<camera>_survey_hint.png and .yaml (what to survey). A restart must lose nothing
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
  // <dir>/<camera>_survey_hint.png: what to survey after a refusal (survey/survey_guidance.h).
  std::string surveyHintPath(const std::string& camera) const;
  // Writes the survey hint atomically. Error: an empty image, or the write failed. save() removes it (the
  // calibration saved supersedes the refusal it described).
  Status saveSurveyHint(const std::string& camera, const cv::Mat& hint) const;
  // <dir>/<camera>_survey_hint.yaml: the same guidance for programs (survey/survey_hint_file.h makes the text).
  // Written atomically; save() removes it too.
  std::string surveyHintYamlPath(const std::string& camera) const;
  Status saveSurveyHintYaml(const std::string& camera, const std::string& yaml_text) const;

  // Removes the temporary files of a write that was killed before its rename: <camera>.yaml.tmp.XXXXXX,
  // <camera>_overlay.png.tmp.XXXXXX, <camera>_survey_hint.png.tmp.XXXXXX, <camera>_survey_hint.yaml.tmp.XXXXXX, the
  // older .<camera>_overlay.tmp.png and the calibration report's <camera>_report*.tmp.XXXXXX
  // (survey/calibration_report.h). Only these names of the cameras given are touched. Returns the paths removed.
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
  // A different calibration already saved is never overwritten silently: it is first copied beside it as
  // <camera>.<UTC time it was written>.yaml (archivedPath; .1, .2, ... when taken), with its overlay as
  // <camera>_overlay.<same time>.png; kept_as receives the YAML copy's path (empty when nothing was kept: no file,
  // or the same calibration saved again).
  Status save(const std::string& camera, const CalibrationFile& calibration, const cv::Mat& overlay,
              std::string* kept_as = nullptr) const;
  // The saved calibration as it is on disk, if readable and valid (no renaming, unlike load).
  std::optional<CalibrationFile> saved(const std::string& camera) const;
  // "<dir>/<camera>.<utc>.yaml" for a UTC time as "20261130T071100Z".
  std::string archivedPath(const std::string& camera, const std::string& utc) const;

private:
  std::string setAside(const std::string& path) const;
  // Copies the saved calibration (and overlay) aside before it is replaced; returns the YAML copy's path.
  Expected<std::string> keepPrevious(const std::string& camera, const CalibrationFile& replacement) const;

  std::string directory_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_IO_CALIBRATION_STORE_H
