#include "insitu_calibration/survey/calibration_report.h"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "insitu_calibration/io/atomic_file.h"
#include "survey/report_figures.h"

namespace insitu_calibration
{
namespace fs = std::filesystem;

namespace
{
// Numbers as the table shows them: 10 significant digits (a reader can parse them back), "n/a" for NaN.
std::string number(double value)
{
  if (std::isnan(value))
    return "n/a";
  if (std::isinf(value))
    return value > 0 ? "inf" : "-inf";
  char text[40];
  std::snprintf(text, sizeof(text), "%.10g", value);
  return text;
}

std::string utcNow()
{
  const std::time_t t = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&t, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M:%S UTC", &utc);
  return text;
}

std::string fileName(const std::string& path)
{
  return fs::path(path).filename().string();
}

// <tr id="param-NAME"><td>NAME</td><td class="value">...</td><td class="sigma">...</td><td>UNIT</td><td>NOTE</td>
void parameterRow(std::ostream& out, const std::string& name, const std::string& value, const std::string& sigma,
                  const std::string& unit, const std::string& note)
{
  out << "<tr id=\"param-" << escapeHtml(name) << "\"><td>" << escapeHtml(name) << "</td><td class=\"value\">"
      << escapeHtml(value) << "</td><td class=\"sigma\">" << escapeHtml(sigma) << "</td><td>" << escapeHtml(unit)
      << "</td><td>" << escapeHtml(note) << "</td></tr>\n";
}

void parameterSection(std::ostream& out, const CalibrationReport& report)
{
  const CameraModel& camera = report.calibration.camera;
  const Intrinsics& k = camera.intrinsics();
  const CameraUncertainty& u = report.calibration.uncertainty;
  const auto sigma = [&](double s) { return u.available ? number(s) : std::string("n/a"); };
  const Eigen::Vector3d c = camera.pose().center();
  const Eigen::Quaterniond q(camera.pose().worldFromCamera().linear());
  out << "<h2>Parameters</h2>\n";
  if (!u.available)
    out << "<p class=\"warn\">No uncertainty: " << escapeHtml(u.reason.empty() ? "not computed" : u.reason) << "</p>\n";
  out << "<table class=\"params\">\n<tr><th>parameter</th><th>value</th><th>one sigma</th><th>unit</th><th>note</th>"
         "</tr>\n";
  parameterRow(out, "fx", number(k.fx), sigma(u.fx), "px", "focal length along x");
  parameterRow(out, "fy", number(k.fy), sigma(u.fy), "px", "focal length along y");
  parameterRow(out, "cx", number(k.cx), sigma(u.cx), "px", "principal point (and distortion centre)");
  parameterRow(out, "cy", number(k.cy), sigma(u.cy), "px", "");
  parameterRow(out, "skew", number(k.skew), "n/a", "px", "");
  parameterRow(out, "lambda", number(camera.distortion().lambda), sigma(u.lambda), "1/px^2",
               "division model; " + report.calibration.distortion_note);
  parameterRow(out, "position", number(c.x()) + ", " + number(c.y()) + ", " + number(c.z()), sigma(u.position_m), "m",
               "optical centre x, y, z in the world; sigma: RMS of the 3D position error");
  parameterRow(out, "rotation", number(q.x()) + ", " + number(q.y()) + ", " + number(q.z()) + ", " + number(q.w()),
               sigma(u.rotation_deg), "deg",
               "optical frame in the world as quaternion x, y, z, w; sigma: RMS rotation angle");
  out << "</table>\n";
}

void qualitySection(std::ostream& out, const CalibrationReport& report)
{
  const CameraCalibration& c = report.calibration;
  const CameraUncertainty& u = c.uncertainty;
  out << "<h2>Quality</h2>\n<table class=\"params\">\n<tr><th>measure</th><th>value</th><th>unit</th></tr>\n";
  const auto row = [&](const std::string& name, const std::string& value, const std::string& unit) {
    out << "<tr id=\"quality-" << escapeHtml(name) << "\"><td>" << escapeHtml(name) << "</td><td class=\"value\">"
        << escapeHtml(value) << "</td><td>" << escapeHtml(unit) << "</td></tr>\n";
  };
  row("rms", number(c.reprojection.rms_px), "px");
  row("median", number(c.reprojection.median_px), "px");
  row("max", number(c.reprojection.max_px), "px");
  row("residuals", number(static_cast<double>(c.reprojection.count)), "");
  row("inlier_lines", number(static_cast<double>(c.inlier_count)), "");
  row("lines", number(static_cast<double>(c.inlier_lines.size())), "");
  row("inlier_threshold", number(c.inlier_threshold_px), "px");
  row("noise_level", u.available ? number(u.residual_sigma_px) : "n/a", "px");
  row("line_correlation_factor", u.available ? number(u.line_correlation_factor) : "n/a", "");
  row("reciprocal_condition", u.available ? number(u.reciprocal_condition) : "n/a", "");
  row("iterations", number(c.iterations), "");
  row("converged", c.converged ? "yes" : "no", "");
  out << "</table>\n<pre>" << escapeHtml(describeCalibration(c)) << "</pre>\n";
}

void lineSection(std::ostream& out, const CalibrationReport& report, const ReportFiles& files)
{
  const std::vector<report::LineRow> rows = report::lineRows(report);
  out << "<h2>Residuals</h2>\n<p>Point-to-line residuals: the distance of each world point's projection (through the "
         "division model) to its image polyline.</p>\n<img src=\""
      << escapeHtml(fileName(files.residuals)) << "\" alt=\"residual histogram\">\n<img src=\""
      << escapeHtml(fileName(files.lines)) << "\" alt=\"RMS residual per line\">\n";
  out << "<table class=\"lines\">\n<tr><th>line</th><th>image points</th><th>world points</th><th>inlier</th>"
         "<th>RMS (px)</th><th>refinement RMS (px)</th><th>held-out RMS (px)</th><th>influence</th>"
         "<th>3D sigma (m)</th></tr>\n";
  for (const report::LineRow& r : rows)
    out << "<tr id=\"line-" << r.id << "\" class=\"" << (r.inlier ? "inlier" : "outlier") << "\"><td>" << r.id
        << "</td><td>" << r.image_points << "</td><td>" << r.world_points << "</td><td>"
        << (r.inlier ? "inlier" : "outlier") << "</td><td>" << number(r.rms_px) << "</td><td>"
        << number(r.refinement_rms_px) << "</td><td>" << number(r.heldout_rms_px) << "</td><td>" << number(r.influence)
        << "</td><td>" << number(r.world_sigma_m) << "</td></tr>\n";
  out << "</table>\n<p>RMS: under the final camera. Refinement RMS: the refinement's own residual of the line. "
         "Held-out RMS: the line's residual had it been left out of the fit (a wrong line that pulled the camera "
         "onto itself has a small RMS but a large held-out RMS). Influence: Cook's distance, how far the camera "
         "would move without the line in units of its uncertainty. n/a: not computed (no refinement, or not used "
         "by it).</p>\n";
}

void coverageAndSurveySection(std::ostream& out, const CalibrationReport& report, const ReportFiles& files)
{
  const double coverage = imageCoverage(report.matched_image_lines, report.image_width, report.image_height);
  out << "<h2>Coverage of the view</h2>\n<p id=\"coverage\">" << number(coverage) << " % of the image ("
      << kCoverageCells << " x " << kCoverageCells
      << " cells) is touched by matched lines. Lines spread over the whole view determine the distortion and the "
         "principal point; a corner without lines is extrapolated.</p>\n<img src=\""
      << escapeHtml(fileName(files.coverage)) << "\" alt=\"coverage\">\n<h2>Survey</h2>\n";
  if (!report.survey)
  {
    out << "<p id=\"survey\">No survey: calibrated from " << escapeHtml(report.source) << ".</p>\n";
    return;
  }
  out << "<table class=\"params\" id=\"survey\">\n"
      << "<tr><td>keyframes</td><td class=\"value\">" << report.survey->keyframes << "</td></tr>\n"
      << "<tr><td>map lines</td><td class=\"value\">" << report.survey->map_lines << "</td></tr>\n"
      << "<tr><td>matched lines</td><td class=\"value\">" << report.matched_image_lines.size() << "</td></tr>\n"
      << "<tr><td>unmatched image lines</td><td class=\"value\">" << report.unmatched_image_lines.size()
      << "</td></tr>\n</table>\n";
}

const char* kStyle =
    "body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}img{max-width:100%;display:block;"
    "margin:0.5em 0}table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:2px 8px;"
    "text-align:right}td:first-child,th:first-child{text-align:left}tr.outlier{background:#fdd}"
    ".refused{color:#b00}.warn{color:#a60}pre{background:#f4f4f4;padding:0.5em;white-space:pre-wrap}";

Status encodeAndWrite(const std::string& path, const cv::Mat& figure)
{
  std::vector<unsigned char> png;
  try
  {
    if (!cv::imencode(".png", figure, png))
      return Error(ErrorCode::kIoError, "cannot encode " + path + " as PNG");
  }
  catch (const cv::Exception& e)
  {
    return Error(ErrorCode::kIoError, "cannot encode " + path + " as PNG: " + e.what());
  }
  return writeFileAtomically(path, std::string(png.begin(), png.end()));
}
}  // namespace

std::string escapeHtml(const std::string& text)
{
  std::string out;
  out.reserve(text.size());
  for (const char ch : text)
    switch (ch)
    {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += ch;
    }
  return out;
}

CalibrationReport fixedCameraReport(const FixedCameraConfig& camera, const FixedCameraResult& result,
                                    const cv::Mat& image, const std::vector<Segment3d>& map_lines,
                                    const std::optional<ReportSurveySummary>& survey)
{
  CalibrationReport report;
  report.camera_name = camera.name;
  report.image_width = result.file.image_width;
  report.image_height = result.file.image_height;
  report.source = camera.correspondence_file.empty()
                      ? "the survey's line map (matched automatically from the camera's prior)"
                      : "the correspondence file " + camera.correspondence_file;
  report.verdict = result.summary;
  report.calibration = result.calibration;
  report.correspondences = result.correspondences;
  report.image = image;
  report.map_lines = map_lines;
  report.checked_map_lines = result.checked_map_lines;
  report.matched_image_lines = result.matched_image_lines;
  report.unmatched_image_lines = result.unmatched_image_lines;
  report.survey = survey;
  return report;
}

ReportFiles reportFiles(const std::string& directory, const std::string& camera)
{
  const std::string base = directory + "/" + camera + "_report";
  return {base + ".html", base + "_overlay.png", base + "_residuals.png", base + "_lines.png", base + "_coverage.png"};
}

std::string formatReportHtml(const CalibrationReport& report)
{
  const ReportFiles files = reportFiles(".", report.camera_name);
  std::ostringstream out;
  out << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>Calibration report: "
      << escapeHtml(report.camera_name) << "</title>\n<style>" << kStyle << "</style>\n</head>\n<body>\n"
      << "<h1>Calibration report: " << escapeHtml(report.camera_name) << "</h1>\n<p>"
      << escapeHtml(report.utc_time.empty() ? utcNow() : report.utc_time) << "; " << report.image_width << " x "
      << report.image_height << " px; calibrated from " << escapeHtml(report.source)
      << ".</p>\n<p id=\"verdict\" class=\""
      << (report.accepted ? "accepted\">Accepted: " : "refused\">Refused (not saved): ") << escapeHtml(report.verdict)
      << "</p>\n<h2>Overlay</h2>\n<img src=\"" << escapeHtml(fileName(files.overlay)) << "\" alt=\"overlay\">\n";
  parameterSection(out, report);
  qualitySection(out, report);
  lineSection(out, report, files);
  coverageAndSurveySection(out, report, files);
  out << "</body>\n</html>\n";
  return out.str();
}

Expected<ReportFiles> writeCalibrationReport(const std::string& directory, const CalibrationReport& report)
{
  const std::string what = "cannot write the calibration report of '" + report.camera_name + "' to " + directory;
  if (report.camera_name.empty() || report.camera_name.find('/') != std::string::npos || report.image_width <= 0 ||
      report.image_height <= 0)
    return Error(ErrorCode::kInvalidInput, what + ": the camera needs a name without '/' and an image size");
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (ec || !fs::is_directory(directory))
    return Error(ErrorCode::kIoError, what + ": it is not a directory and cannot be made one (" +
                                          (ec ? ec.message() : std::string("a file is in the way")) + ")");
  const ReportFiles files = reportFiles(directory, report.camera_name);
  const std::vector<report::LineRow> rows = report::lineRows(report);
  const double threshold = report.calibration.inlier_threshold_px;
  const std::vector<std::pair<std::string, cv::Mat>> figures = {
      {files.overlay, report::overlayFigure(report)},
      {files.residuals, report::residualHistogram(rows, threshold)},
      {files.lines, report::lineResidualChart(rows, threshold)},
      {files.coverage, report::coverageFigure(report)}};
  for (const auto& [path, figure] : figures)
    if (const Status written = encodeAndWrite(path, figure); !written)
      return Error(ErrorCode::kIoError, what + ": " + written.error().message());
  if (const Status written = writeFileAtomically(files.html, formatReportHtml(report)); !written)
    return Error(ErrorCode::kIoError, what + ": " + written.error().message());
  return files;
}

}  // namespace insitu_calibration
