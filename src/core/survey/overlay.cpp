#include "insitu_calibration/survey/overlay.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/survey/image_explanation.h"

namespace insitu_calibration
{
namespace
{
const cv::Scalar kMapLineColour(40, 40, 230);        // red (BGR)
const cv::Scalar kMatchedLineColour(60, 200, 60);    // green
const cv::Scalar kUnmatchedLineColour(0, 215, 255);  // yellow
const cv::Scalar kLeftOutLineColour(235, 160, 60);   // blue: map lines the final check left out

cv::Point toPoint(const Eigen::Vector2d& m)
{
  return cv::Point(cvRound(m.x() * 16.0), cvRound(m.y() * 16.0));
}

void drawPolyline(cv::Mat* canvas, const std::vector<Eigen::Vector2d>& points, const cv::Scalar& colour, int thickness)
{
  for (size_t j = 1; j < points.size(); ++j)
    cv::line(*canvas, toPoint(points[j - 1]), toPoint(points[j]), colour, thickness, cv::LINE_AA, 4);
}

// A map line's projection where it is in view (25 points along its visible interval); empty when out of view.
std::vector<Eigen::Vector2d> curveInView(const CameraModel& camera, const Segment3d& segment, int width, int height)
{
  std::vector<Eigen::Vector2d> curve;
  const auto interval = visibleInterval(camera, segment, width, height);
  if (!interval)
    return curve;
  for (int k = 0; k <= 24; ++k)
    if (const auto m =
            camera.project(segment.pointAt(interval->first + (interval->second - interval->first) * k / 24.0)))
      curve.push_back(*m);
  return curve;
}

// Thin dashes along a polyline (dash and gap about 6 thicknesses long).
void drawDashedPolyline(cv::Mat* canvas, const std::vector<Eigen::Vector2d>& points, const cv::Scalar& colour,
                        int thickness)
{
  const double dash = 6.0 * thickness;
  double along = 0.0;
  for (size_t j = 1; j < points.size(); ++j)
  {
    const Eigen::Vector2d a = points[j - 1], d = points[j] - a;
    const double length = d.norm();
    if (!std::isfinite(length))
      continue;
    for (double t = 0.0; t < length;)
    {
      const double phase = std::fmod(along + t, 2.0 * dash);
      const double step = std::min(length - t, (phase < dash ? dash : 2.0 * dash) - phase);
      if (phase < dash && step > 0.0)
        cv::line(*canvas, toPoint(a + d * (t / length)), toPoint(a + d * ((t + step) / length)), colour, thickness,
                 cv::LINE_AA, 4);
      t += std::max(step, 1e-3);
    }
    along += length;
  }
}

// The map lines' samples: wide where an image edge lies under two consecutive samples, thin dashes elsewhere.
void drawSupportedMapLines(cv::Mat* canvas, const std::vector<EdgeSamples>& lines, int thickness)
{
  for (const EdgeSamples& line : lines)
    for (size_t k = 1; k < line.points.size(); ++k)
    {
      const bool supported = line.on_edge[k - 1] && line.on_edge[k];
      if (supported || (k / 2) % 2 == 0)
        cv::line(*canvas, toPoint(line.points[k - 1]), toPoint(line.points[k]), kMapLineColour,
                 supported ? 2 * thickness + 1 : thickness, cv::LINE_AA, 4);
    }
}
}  // namespace

cv::Mat drawOverlay(const cv::Mat& image, int width, int height, const CameraModel& camera,
                    const std::vector<Segment3d>& map_lines,
                    const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines,
                    const std::vector<std::vector<Eigen::Vector2d>>& unmatched_image_lines)
{
  cv::Mat canvas;
  if (image.empty())
    canvas = cv::Mat(height, width, CV_8UC3, cv::Scalar(0, 0, 0));
  else if (image.channels() == 1)
    cv::cvtColor(image, canvas, cv::COLOR_GRAY2BGR);
  else
    canvas = image.clone();
  const int thickness = std::max(1, width / 640);
  for (const auto& line : unmatched_image_lines)
    drawPolyline(&canvas, line, kUnmatchedLineColour, thickness);
  for (const auto& segment : map_lines)  // wider: visible beside a matched line
    drawPolyline(&canvas, curveInView(camera, segment, width, height), kMapLineColour, 2 * thickness + 1);
  for (const auto& line : matched_image_lines)
    drawPolyline(&canvas, line, kMatchedLineColour, thickness);
  return canvas;
}

namespace
{
// Every map line in view first in blue dashes (left out of the final check); the parts the check counted over them,
// wide red on an image edge and thin red elsewhere (as thick as the dashes at least: they cover them).
void drawCheckedMapLines(cv::Mat* canvas, const CameraModel& camera, int width, int height,
                         const std::vector<Segment3d>& map_lines, const std::vector<EdgeSamples>& checked_map_lines,
                         int thickness)
{
  for (const auto& segment : map_lines)
    drawDashedPolyline(canvas, curveInView(camera, segment, width, height), kLeftOutLineColour, thickness);
  for (const EdgeSamples& line : checked_map_lines)
    for (size_t k = 1; line.counted && k < line.points.size(); ++k)
    {
      if (!line.countedAt(k - 1) || !line.countedAt(k))
        continue;
      const bool supported = line.on_edge[k - 1] && line.on_edge[k];
      cv::line(*canvas, toPoint(line.points[k - 1]), toPoint(line.points[k]), kMapLineColour,
               supported ? 2 * thickness + 1 : thickness, cv::LINE_AA, 4);
    }
}

// A report's overlay: the image with its unmatched image lines, the map lines as draw_map_lines(canvas, thickness)
// draws them, the matched image lines on top. Without an image: drawOverlay.
template <typename DrawMapLines>
cv::Mat reportOverlay(const cv::Mat& image, int width, int height, const CameraModel& camera,
                      const std::vector<Segment3d>& map_lines,
                      const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines,
                      const std::vector<std::vector<Eigen::Vector2d>>& unmatched_image_lines,
                      DrawMapLines draw_map_lines)
{
  if (image.empty())
    return drawOverlay(image, width, height, camera, map_lines, matched_image_lines, unmatched_image_lines);
  cv::Mat canvas = drawOverlay(image, width, height, camera, {}, {}, unmatched_image_lines);
  const int thickness = std::max(1, width / 640);
  draw_map_lines(&canvas, thickness);
  for (const auto& line : matched_image_lines)
    drawPolyline(&canvas, line, kMatchedLineColour, thickness);
  return canvas;
}
}  // namespace

cv::Mat drawOverlayWithHiddenEdges(const cv::Mat& image, int width, int height, const CameraModel& camera,
                                   const std::vector<Segment3d>& map_lines,
                                   const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines,
                                   const std::vector<std::vector<Eigen::Vector2d>>& unmatched_image_lines)
{
  return reportOverlay(image, width, height, camera, map_lines, matched_image_lines, unmatched_image_lines,
                       [&](cv::Mat* canvas, int thickness) {
                         drawSupportedMapLines(canvas, sampleEdgeSupport(image, camera, width, height, map_lines),
                                               thickness);
                       });
}

cv::Mat drawFinalCheckOverlay(const cv::Mat& image, int width, int height, const CameraModel& camera,
                              const std::vector<Segment3d>& map_lines,
                              const std::vector<EdgeSamples>& checked_map_lines,
                              const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines,
                              const std::vector<std::vector<Eigen::Vector2d>>& unmatched_image_lines)
{
  return reportOverlay(image, width, height, camera, map_lines, matched_image_lines, unmatched_image_lines,
                       [&](cv::Mat* canvas, int thickness) {
                         drawCheckedMapLines(canvas, camera, width, height, map_lines, checked_map_lines, thickness);
                       });
}

void drawOverlayLegend(cv::Mat* canvas, bool with_unmatched, MapLineLegend map_lines)
{
  enum Style
  {
    kWide,
    kThin,
    kThinDashed
  };
  struct Entry
  {
    cv::Scalar colour;
    std::string text;
    Style style;
  };
  std::vector<Entry> entries;
  switch (map_lines)
  {
    case MapLineLegend::kThroughCalibration:
      entries.push_back({kMapLineColour, "map lines through the calibration", kWide});
      break;
    case MapLineLegend::kEdgeSupport:
      entries.push_back({kMapLineColour, "map lines on an image edge", kWide});
      entries.push_back({kMapLineColour, "map lines with no image edge (hidden or faint)", kThinDashed});
      break;
    case MapLineLegend::kFinalCheck:
      entries.push_back({kMapLineColour, "map lines on an image edge", kWide});
      entries.push_back({kMapLineColour, "map lines with no image edge (count against the camera)", kThin});
      entries.push_back(
          {kLeftOutLineColour, "map lines the check left out (hidden, plain floor or texture, short)", kThinDashed});
      break;
  }
  entries.push_back({kMatchedLineColour, "matched image lines", kWide});
  if (with_unmatched)
    entries.push_back({kUnmatchedLineColour, "unmatched image lines", kWide});
  const double scale = std::max(0.5, canvas->cols / 1280.0);
  const int row = cvRound(28 * scale), pad = cvRound(10 * scale), sample = cvRound(40 * scale);
  const int font = cv::FONT_HERSHEY_SIMPLEX, text_thickness = std::max(1, cvRound(scale));
  int text_width = 0;
  for (const auto& entry : entries)
    text_width = std::max(text_width, cv::getTextSize(entry.text, font, 0.6 * scale, text_thickness, nullptr).width);
  const cv::Rect box(pad, pad, std::min(canvas->cols - 2 * pad, 3 * pad + sample + text_width),
                     std::min(canvas->rows - 2 * pad, row * static_cast<int>(entries.size()) + pad));
  if (box.width <= 0 || box.height <= 0)
    return;
  cv::Mat region = (*canvas)(box);
  region = region * 0.25 + cv::Scalar(40, 40, 40) * 0.75;  // a dark box that keeps a hint of the image
  for (size_t k = 0; k < entries.size(); ++k)
  {
    const int y = box.y + pad / 2 + row * static_cast<int>(k) + row / 2;
    const int dashes = entries[k].style == kThinDashed ? 4 : 1;
    for (int d = 0; d < dashes; ++d)  // a dashed sample: 4 dashes with gaps of their length
      cv::line(*canvas, cv::Point(box.x + pad + sample * 2 * d / (2 * dashes - 1), y),
               cv::Point(box.x + pad + sample * (2 * d + 1) / (2 * dashes - 1), y), entries[k].colour,
               entries[k].style == kWide ? std::max(2, cvRound(3 * scale)) : std::max(1, cvRound(scale)), cv::LINE_AA);
    cv::putText(*canvas, entries[k].text, cv::Point(box.x + 2 * pad + sample, y + cvRound(6 * scale)), font,
                0.6 * scale, cv::Scalar(255, 255, 255), text_thickness, cv::LINE_AA);
  }
}

cv::Mat drawCalibrationOverlay(const cv::Mat& image, int width, int height, const CameraModel& camera,
                               const std::vector<Segment3d>& map_lines,
                               const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines)
{
  cv::Mat canvas = drawOverlay(image, width, height, camera, map_lines, matched_image_lines);
  drawOverlayLegend(&canvas, false);
  return canvas;
}

std::vector<Segment3d> frustumSegments(const CameraModel& camera, int width, int height, double depth_m)
{
  const Eigen::Isometry3d world_from_camera = camera.pose().worldFromCamera();
  const Eigen::Vector3d apex = world_from_camera.translation();
  std::vector<Eigen::Vector3d> corners;
  for (const Eigen::Vector2d& pixel : {Eigen::Vector2d(0, 0), Eigen::Vector2d(width - 1, 0),
                                       Eigen::Vector2d(width - 1, height - 1), Eigen::Vector2d(0, height - 1)})
  {
    const auto ray = camera.backProject(pixel);
    const Eigen::Vector3d r = ray ? *ray : Eigen::Vector3d::UnitZ();
    corners.push_back(world_from_camera * (r * (depth_m / r.z())));
  }
  std::vector<Segment3d> out;
  for (size_t k = 0; k < 4; ++k)
  {
    out.push_back({apex, corners[k]});
    out.push_back({corners[k], corners[(k + 1) % 4]});
  }
  return out;
}

}  // namespace insitu_calibration
