#include "survey/report_figures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/metrics.h"
#include "insitu_calibration/robust_statistics.h"
#include "insitu_calibration/survey/fixed_camera.h"
#include "insitu_calibration/survey/overlay.h"

namespace insitu_calibration
{
namespace report
{
namespace
{
const cv::Scalar kInlierColour(60, 170, 60);   // green (BGR)
const cv::Scalar kOutlierColour(50, 50, 210);  // red
const cv::Scalar kThresholdColour(200, 90, 20);
const cv::Scalar kInk(30, 30, 30);
const int kFont = cv::FONT_HERSHEY_SIMPLEX;

std::string format(const char* pattern, double value)
{
  char text[64];
  std::snprintf(text, sizeof(text), pattern, value);
  return text;
}

// A step of 1, 2 or 5 times a power of ten that cuts the range into about `target` parts.
double niceStep(double range, int target)
{
  const double raw = std::max(range, 1e-12) / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0})
    if (m * magnitude >= raw)
      return m * magnitude;
  return 10.0 * magnitude;
}

struct Chart
{
  cv::Mat canvas;
  cv::Rect plot;
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  cv::Point at(double x, double y) const
  {
    return cv::Point(cvRound(plot.x + (x - x0) / (x1 - x0) * plot.width),
                     cvRound(plot.y + plot.height - (y - y0) / (y1 - y0) * plot.height));
  }
};

void putCentred(cv::Mat& canvas, const std::string& text, cv::Point centre, double scale, int thickness = 1)
{
  const cv::Size size = cv::getTextSize(text, kFont, scale, thickness, nullptr);
  cv::putText(canvas, text, centre + cv::Point(-size.width / 2, size.height / 2), kFont, scale, kInk, thickness,
              cv::LINE_AA);
}

// The y-axis label, written sideways (OpenCV writes horizontally only: drawn apart and turned).
void putVertical(cv::Mat& canvas, const std::string& text, cv::Point centre, double scale)
{
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, nullptr);
  cv::Mat label(size.height + 8, size.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(label, text, cv::Point(2, size.height + 2), kFont, scale, kInk, 1, cv::LINE_AA);
  cv::rotate(label, label, cv::ROTATE_90_COUNTERCLOCKWISE);
  const cv::Rect target(centre.x - label.cols / 2, centre.y - label.rows / 2, label.cols, label.rows);
  if ((target & cv::Rect(0, 0, canvas.cols, canvas.rows)) == target)
    label.copyTo(canvas(target));
}

// White canvas, plot frame, grid, tick labels, axis labels with units, title.
Chart makeChart(const std::string& title, const std::string& x_label, const std::string& y_label, double x0, double x1,
                double y1, bool integer_x)
{
  Chart c;
  c.canvas = cv::Mat(kChartHeight, kChartWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  c.plot = cv::Rect(90, 60, kChartWidth - 120, kChartHeight - 140);
  c.x0 = x0;
  c.x1 = x1 > x0 ? x1 : x0 + 1.0;
  c.y0 = 0.0;
  c.y1 = y1 > 0 ? y1 : 1.0;
  const double y_step = niceStep(c.y1, 6);
  for (double y = 0.0; y <= c.y1 + 1e-9 * y_step; y += y_step)
  {
    cv::line(c.canvas, c.at(c.x0, y), c.at(c.x1, y), cv::Scalar(225, 225, 225), 1);
    const std::string label = format(y_step >= 1.0 ? "%.0f" : (y_step >= 0.1 ? "%.1f" : "%.2f"), y);
    const cv::Size size = cv::getTextSize(label, kFont, 0.5, 1, nullptr);
    cv::putText(c.canvas, label, c.at(c.x0, y) + cv::Point(-size.width - 8, size.height / 2), kFont, 0.5, kInk, 1,
                cv::LINE_AA);
  }
  double x_step = niceStep(c.x1 - c.x0, 8);
  if (integer_x)
    x_step = std::max(1.0, std::round(x_step));
  for (double x = std::ceil(c.x0 / x_step) * x_step; x <= c.x1 + 1e-9 * x_step; x += x_step)
  {
    cv::line(c.canvas, c.at(x, 0.0), c.at(x, 0.0) + cv::Point(0, 5), kInk, 1);
    const double shown = std::abs(x) < 1e-9 * x_step ? 0.0 : x;  // no "-0"
    putCentred(c.canvas, format(x_step >= 1.0 ? "%.0f" : (x_step >= 0.1 ? "%.1f" : "%.2f"), shown),
               c.at(x, 0.0) + cv::Point(0, 16), 0.5);
  }
  cv::rectangle(c.canvas, c.plot, kInk, 1);
  putCentred(c.canvas, x_label, cv::Point(c.plot.x + c.plot.width / 2, kChartHeight - 35), 0.6);
  putVertical(c.canvas, y_label, cv::Point(22, c.plot.y + c.plot.height / 2), 0.6);
  putCentred(c.canvas, title, cv::Point(kChartWidth / 2, 28), 0.6);
  return c;
}

void dashedLine(cv::Mat& canvas, cv::Point a, cv::Point b, const cv::Scalar& colour, int thickness)
{
  const double length = cv::norm(b - a);
  for (double s = 0.0; s < length; s += 12.0)
  {
    const double e = std::min(length, s + 7.0);
    cv::line(canvas, a + (b - a) * (s / length), a + (b - a) * (e / length), colour, thickness, cv::LINE_AA);
  }
}

// Filled swatches (or a dashed line for the threshold) with their texts, in the plot's top-right corner.
void chartLegend(Chart& c, const std::vector<std::pair<cv::Scalar, std::string>>& entries, const std::string& dashed)
{
  int width = 0;
  for (const auto& e : entries)
    width = std::max(width, cv::getTextSize(e.second, kFont, 0.5, 1, nullptr).width);
  width = std::max(width, cv::getTextSize(dashed, kFont, 0.5, 1, nullptr).width);
  const int rows = static_cast<int>(entries.size()) + (dashed.empty() ? 0 : 1);
  const cv::Rect box(c.plot.x + c.plot.width - width - 60, c.plot.y + 10, width + 50, 24 * rows + 8);
  cv::rectangle(c.canvas, box, cv::Scalar(255, 255, 255), cv::FILLED);
  cv::rectangle(c.canvas, box, cv::Scalar(180, 180, 180), 1);
  for (int k = 0; k < rows; ++k)
  {
    const cv::Point p(box.x + 8, box.y + 8 + 24 * k);
    const bool is_dashed = k == static_cast<int>(entries.size());
    if (is_dashed)
      dashedLine(c.canvas, p + cv::Point(0, 8), p + cv::Point(26, 8), kThresholdColour, 2);
    else
      cv::rectangle(c.canvas, cv::Rect(p.x, p.y, 26, 16), entries[k].first, cv::FILLED);
    cv::putText(c.canvas, is_dashed ? dashed : entries[k].second, p + cv::Point(34, 13), kFont, 0.5, kInk, 1,
                cv::LINE_AA);
  }
}

double percentile(std::vector<double> values, double q)
{
  if (values.empty())
    return 0.0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}
}  // namespace

std::vector<LineRow> lineRows(const CalibrationReport& report)
{
  const CameraCalibration& c = report.calibration;
  // The refinement ran on the inlier lines alone: its per-line values follow the inliers' order. A size that does
  // not match (the inliers judged again after the last refinement) shows none rather than another line's.
  const size_t inliers = std::count(c.inlier_lines.begin(), c.inlier_lines.end(), true);
  const RefinementResult* r = c.refinement && c.refinement->line_rms_px.size() == inliers &&
                                      c.refinement->line_loo_rms_px.size() == inliers &&
                                      c.refinement->line_influence.size() == inliers
                                  ? &*c.refinement
                                  : nullptr;
  std::vector<LineRow> rows;
  size_t k = 0;  // the line's place among the inliers
  for (size_t i = 0; i < report.correspondences.lines.size(); ++i)
  {
    const LineCorrespondence& line = report.correspondences.lines[i];
    LineRow row;
    row.id = i;
    row.image_points = line.image.size();
    row.world_points = line.world.size();
    row.inlier = i < c.inlier_lines.size() && c.inlier_lines[i];
    row.residuals_px = lineResiduals(c.camera, line);
    row.rms_px = rootMeanSquare(row.residuals_px);
    if (r && row.inlier)
    {
      row.refinement_rms_px = r->line_rms_px[k];
      row.heldout_rms_px = r->line_loo_rms_px[k];
      row.influence = r->line_influence[k];
    }
    k += row.inlier ? 1 : 0;
    row.world_sigma_m = line.world_sigma_m;
    rows.push_back(std::move(row));
  }
  return rows;
}

cv::Mat overlayFigure(const CalibrationReport& report)
{
  const bool with_unmatched = !report.unmatched_image_lines.empty();
  if (report.image.empty())
  {
    cv::Mat canvas = drawOverlay(report.image, report.image_width, report.image_height, report.calibration.camera,
                                 report.map_lines, report.matched_image_lines, report.unmatched_image_lines);
    drawOverlayLegend(&canvas, with_unmatched);
    return canvas;
  }
  if (report.checked_map_lines.empty())  // no final check (a correspondence file, or refused before it)
  {
    cv::Mat canvas =
        drawOverlayWithHiddenEdges(report.image, report.image_width, report.image_height, report.calibration.camera,
                                   report.map_lines, report.matched_image_lines, report.unmatched_image_lines);
    drawOverlayLegend(&canvas, with_unmatched, MapLineLegend::kEdgeSupport);
    return canvas;
  }
  cv::Mat canvas = drawFinalCheckOverlay(report.image, report.image_width, report.image_height,
                                         report.calibration.camera, report.map_lines, report.checked_map_lines,
                                         report.matched_image_lines, report.unmatched_image_lines);
  drawOverlayLegend(&canvas, with_unmatched, MapLineLegend::kFinalCheck);
  return canvas;
}

cv::Mat residualHistogram(const std::vector<LineRow>& rows, double inlier_threshold_px)
{
  // A refused result's camera may put points anywhere: a residual that is not finite (a point behind the camera)
  // is counted with those beyond the axis, and no residual picks a bin outside the chart.
  std::vector<double> all, inliers;
  for (const LineRow& row : rows)
    for (const double r : row.residuals_px)
      if (std::isfinite(r))
      {
        all.push_back(r);
        if (row.inlier)
          inliers.push_back(r);
      }
  const double x_max = std::max({1.05 * percentile(all, 0.99), 1.2 * inlier_threshold_px, 0.1});
  constexpr int kBins = 30;
  std::vector<int> in(kBins, 0), out(kBins, 0);
  size_t clipped = 0;
  for (const LineRow& row : rows)
    for (const double r : row.residuals_px)
    {
      const double position = std::isfinite(r) ? std::max(0.0, r) / x_max * kBins : kBins;
      clipped += position >= kBins ? 1 : 0;
      const int bin = position >= kBins ? kBins - 1 : static_cast<int>(position);
      (row.inlier ? in : out)[bin] += 1;
    }
  int y_max = 1;
  for (int b = 0; b < kBins; ++b)
    y_max = std::max(y_max, in[b] + out[b]);
  const ReprojectionStats stats = summarize(inliers);  // as the calibration's quality reports them
  const std::string title = format("%.0f residuals", static_cast<double>(all.size())) +
                            format(" (inlier lines: RMS %.3f px, ", stats.rms_px) +
                            format("median %.3f px)", stats.median_px);
  Chart c = makeChart(title,
                      clipped ? format("point-to-line residual (px); the last bar holds %.0f beyond", clipped)
                              : "point-to-line residual (px)",
                      "number of residuals", 0.0, x_max, 1.1 * y_max, false);
  for (int b = 0; b < kBins; ++b)
  {
    const double left = x_max * b / kBins, right = x_max * (b + 1) / kBins;
    if (in[b] > 0)
      cv::rectangle(c.canvas, c.at(left, 0) + cv::Point(1, 0), c.at(right, in[b]) - cv::Point(1, 0), kInlierColour,
                    cv::FILLED);
    if (out[b] > 0)
      cv::rectangle(c.canvas, c.at(left, in[b]) + cv::Point(1, 0), c.at(right, in[b] + out[b]) - cv::Point(1, 0),
                    kOutlierColour, cv::FILLED);
  }
  if (inlier_threshold_px > 0.0)
    dashedLine(c.canvas, c.at(inlier_threshold_px, 0), c.at(inlier_threshold_px, c.y1), kThresholdColour, 2);
  chartLegend(c, {{kInlierColour, "inlier lines"}, {kOutlierColour, "outlier lines"}},
              inlier_threshold_px > 0.0 ? format("inlier threshold %.2f px", inlier_threshold_px) : "");
  return c.canvas;
}

cv::Mat lineResidualChart(const std::vector<LineRow>& rows, double inlier_threshold_px)
{
  std::vector<double> values;  // the finite ones: a NaN would break the percentile's ordering
  for (const LineRow& row : rows)
    if (std::isfinite(row.rms_px))
      values.push_back(row.rms_px);
  const double y_max = std::max({1.1 * percentile(values, 0.95), 1.3 * inlier_threshold_px, 0.1});
  Chart c = makeChart(format("RMS point-to-line residual of each of the %.0f lines", static_cast<double>(rows.size())),
                      "line id (row of the table)", "RMS residual (px)", -0.5,
                      std::max(0.5, static_cast<double>(rows.size()) - 0.5), y_max, true);
  for (const LineRow& row : rows)
  {
    const double id = static_cast<double>(row.id);
    const double height = std::isfinite(row.rms_px) ? std::min(row.rms_px, y_max) : y_max;
    const cv::Scalar& colour = row.inlier ? kInlierColour : kOutlierColour;
    cv::rectangle(c.canvas, c.at(id - 0.4, 0), c.at(id + 0.4, height), colour, cv::FILLED);
    if (height < row.rms_px || !std::isfinite(row.rms_px))  // beyond the axis: a mark at its top
      cv::circle(c.canvas, c.at(id, y_max) + cv::Point(0, 6), 4, kInk, cv::FILLED, cv::LINE_AA);
  }
  if (inlier_threshold_px > 0.0)
    dashedLine(c.canvas, c.at(c.x0, inlier_threshold_px), c.at(c.x1, inlier_threshold_px), kThresholdColour, 2);
  chartLegend(c, {{kInlierColour, "inlier line"}, {kOutlierColour, "outlier line"}},
              inlier_threshold_px > 0.0 ? format("inlier threshold %.2f px", inlier_threshold_px) : "");
  return c.canvas;
}

cv::Mat coverageFigure(const CalibrationReport& report)
{
  const int w = report.image_width, h = report.image_height;
  cv::Mat canvas = drawOverlay(report.image, w, h, report.calibration.camera, {}, report.matched_image_lines);
  const std::vector<bool> cells = imageCoverageCells(report.matched_image_lines, w, h);
  cv::Mat tint = canvas.clone();
  for (int k = 0; k < kCoverageCells * kCoverageCells; ++k)
  {
    const cv::Rect cell((k % kCoverageCells) * w / kCoverageCells, (k / kCoverageCells) * h / kCoverageCells,
                        w / kCoverageCells, h / kCoverageCells);
    cv::rectangle(tint, cell, cells[k] ? kInlierColour : kOutlierColour, cv::FILLED);
  }
  cv::addWeighted(canvas, 0.7, tint, 0.3, 0.0, canvas);
  const int thickness = std::max(1, w / 640);
  for (int k = 1; k < kCoverageCells; ++k)
  {
    cv::line(canvas, cv::Point(k * w / kCoverageCells, 0), cv::Point(k * w / kCoverageCells, h), cv::Scalar::all(255),
             thickness);
    cv::line(canvas, cv::Point(0, k * h / kCoverageCells), cv::Point(w, k * h / kCoverageCells), cv::Scalar::all(255),
             thickness);
  }
  const size_t touched = std::count(cells.begin(), cells.end(), true);
  const double scale = std::max(0.5, w / 1280.0);
  const std::string text =
      format("coverage %.0f %%: ", imageCoverage(report.matched_image_lines, w, h)) +
      format("%.0f of ", static_cast<double>(touched)) +
      format("%.0f cells touched by matched lines (green; red: none)", static_cast<double>(cells.size()));
  const cv::Size size = cv::getTextSize(text, kFont, 0.7 * scale, std::max(1, cvRound(scale)), nullptr);
  const cv::Rect box(0, h - size.height - cvRound(24 * scale), std::min(w, size.width + cvRound(20 * scale)),
                     size.height + cvRound(24 * scale));
  cv::rectangle(canvas, box & cv::Rect(0, 0, w, h), cv::Scalar(40, 40, 40), cv::FILLED);
  cv::putText(canvas, text, cv::Point(cvRound(10 * scale), h - cvRound(12 * scale)), kFont, 0.7 * scale,
              cv::Scalar::all(255), std::max(1, cvRound(scale)), cv::LINE_AA);
  return canvas;
}

}  // namespace report
}  // namespace insitu_calibration
