// A calibration report for people, written beside the calibration YAML: <camera>_report.html and its figures
// <camera>_report_overlay.png (the map's lines through the camera over its image, with a legend),
// <camera>_report_residuals.png (histogram of the point-to-line residuals, px), <camera>_report_lines.png (RMS per
// line, px) and <camera>_report_coverage.png (the image cells the used lines touch). The HTML holds the parameters
// with their one-sigma values, the per-line residuals, the coverage and the survey's summary, and refers to the
// figures by relative path: the files can be copied elsewhere together. OpenCV draws everything (no Python).
#ifndef INSITU_CALIBRATION_SURVEY_CALIBRATION_REPORT_H
#define INSITU_CALIBRATION_SURVEY_CALIBRATION_REPORT_H

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "insitu_calibration/calibration.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/survey/fixed_camera.h"

namespace insitu_calibration
{
// The survey the camera was calibrated against.
struct ReportSurveySummary
{
  size_t keyframes = 0;  // RGB-D keyframes of the robot's survey
  size_t map_lines = 0;  // map lines the camera was matched against (enough support)
};

struct CalibrationReport
{
  std::string camera_name;
  int image_width = 0;
  int image_height = 0;
  std::string source;    // what the camera was calibrated from, in words
  bool accepted = true;  // false: the result was refused (the YAML was not written from it)
  std::string verdict;   // why accepted (the result's summary) or refused (the error)
  std::string utc_time;  // when; empty: now
  CameraCalibration calibration;
  CorrespondenceSet correspondences;  // the lines calibrated on; calibration.inlier_lines indexes them
  cv::Mat image;                      // the camera's (median) image; empty: a black canvas
  std::vector<Segment3d> map_lines;   // drawn through the camera (empty without a map)
  // The map lines as the final check saw them (FixedCameraResult::checked_map_lines; empty: not checked): the overlay
  // then shows what counted and what was left out.
  std::vector<EdgeSamples> checked_map_lines;
  std::vector<std::vector<Eigen::Vector2d>> matched_image_lines;
  std::vector<std::vector<Eigen::Vector2d>> unmatched_image_lines;
  std::optional<ReportSurveySummary> survey;  // none: calibrated without a survey (calibrate_lines)
};

// The report of a fixed camera's result (FixedCamera::calibrate, Survey::calibrate), accepted with its summary.
CalibrationReport fixedCameraReport(const FixedCameraConfig& camera, const FixedCameraResult& result,
                                    const cv::Mat& image, const std::vector<Segment3d>& map_lines,
                                    const std::optional<ReportSurveySummary>& survey);

// The size of the charts (residual histogram, RMS per line); the overlay and the coverage have the image's size.
constexpr int kReportChartWidth = 900;
constexpr int kReportChartHeight = 520;

struct ReportFiles
{
  std::string html;
  std::string overlay;
  std::string residuals;
  std::string lines;
  std::string coverage;
};
// The files of <camera>'s report in a directory.
ReportFiles reportFiles(const std::string& directory, const std::string& camera);

// Draws the figures and writes them and the HTML, each atomically (a temporary file renamed over the target: a
// reader sees the previous file or the new one, never a part), figures first so that the HTML never refers to a
// figure not yet written. Creates the directory when missing. Errors: the directory cannot be created or written,
// a figure cannot be encoded; what was written before the error stays (complete files only).
Expected<ReportFiles> writeCalibrationReport(const std::string& directory, const CalibrationReport& report);

// The HTML page alone (figures referred to by file name).
std::string formatReportHtml(const CalibrationReport& report);
// &, <, >, " and ' as HTML entities.
std::string escapeHtml(const std::string& text);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_CALIBRATION_REPORT_H
