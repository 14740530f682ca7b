// The calibration report's figures (calibration_report.h), drawn with OpenCV: charts with axes, ticks, labels with
// units and legends.
#ifndef INSITU_CALIBRATION_SURVEY_REPORT_FIGURES_H
#define INSITU_CALIBRATION_SURVEY_REPORT_FIGURES_H

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "insitu_calibration/survey/calibration_report.h"

namespace insitu_calibration
{
namespace report
{
constexpr int kChartWidth = kReportChartWidth;
constexpr int kChartHeight = kReportChartHeight;

// One line of the report's table: what the correspondences and the result hold about it.
struct LineRow
{
  size_t id = 0;  // index in the correspondences
  size_t image_points = 0;
  size_t world_points = 0;
  bool inlier = false;
  double rms_px = 0.0;             // point-to-line RMS under the final camera (metrics.h lineResiduals)
  double refinement_rms_px = NAN;  // RefinementResult::line_rms_px (NaN: not refined / not used)
  double heldout_rms_px = NAN;     // RefinementResult::line_loo_rms_px
  double influence = NAN;          // RefinementResult::line_influence (Cook's distance)
  double world_sigma_m = 0.0;
  std::vector<double> residuals_px;  // lineResiduals
};
std::vector<LineRow> lineRows(const CalibrationReport& report);

// The overlay (overlay.h) with its legend.
cv::Mat overlayFigure(const CalibrationReport& report);
// Histogram of the point-to-line residuals of inlier lines and of outlier lines (stacked), with the inlier threshold.
cv::Mat residualHistogram(const std::vector<LineRow>& rows, double inlier_threshold_px);
// The RMS of each line (bars by line id, inliers and outliers coloured), with the inlier threshold.
cv::Mat lineResidualChart(const std::vector<LineRow>& rows, double inlier_threshold_px);
// The image with the coverage grid: cells the matched lines touch tinted green, the others red.
cv::Mat coverageFigure(const CalibrationReport& report);

}  // namespace report
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_REPORT_FIGURES_H
