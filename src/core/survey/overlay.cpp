#include "insitu_calibration/survey/overlay.h"

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

cv::Point toPoint(const Eigen::Vector2d& m)
{
  return cv::Point(cvRound(m.x() * 16.0), cvRound(m.y() * 16.0));
}

void drawPolyline(cv::Mat* canvas, const std::vector<Eigen::Vector2d>& points, const cv::Scalar& colour, int thickness)
{
  for (size_t j = 1; j < points.size(); ++j)
    cv::line(*canvas, toPoint(points[j - 1]), toPoint(points[j]), colour, thickness, cv::LINE_AA, 4);
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
  for (const auto& segment : map_lines)
  {
    const auto interval = visibleInterval(camera, segment, width, height);
    if (!interval)
      continue;
    std::vector<Eigen::Vector2d> curve;
    for (int k = 0; k <= 24; ++k)
    {
      const auto m = camera.project(segment.pointAt(interval->first + (interval->second - interval->first) * k / 24.0));
      if (m)
        curve.push_back(*m);
    }
    drawPolyline(&canvas, curve, kMapLineColour, 2 * thickness + 1);  // wider: visible beside a matched line
  }
  for (const auto& line : matched_image_lines)
    drawPolyline(&canvas, line, kMatchedLineColour, thickness);
  return canvas;
}

cv::Mat drawOverlayWithHiddenEdges(const cv::Mat& image, int width, int height, const CameraModel& camera,
                                   const std::vector<Segment3d>& map_lines,
                                   const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines,
                                   const std::vector<std::vector<Eigen::Vector2d>>& unmatched_image_lines)
{
  if (image.empty())
    return drawOverlay(image, width, height, camera, map_lines, matched_image_lines, unmatched_image_lines);
  cv::Mat canvas = drawOverlay(image, width, height, camera, {}, {}, unmatched_image_lines);
  const int thickness = std::max(1, width / 640);
  drawSupportedMapLines(&canvas, sampleEdgeSupport(image, camera, width, height, map_lines), thickness);
  for (const auto& line : matched_image_lines)
    drawPolyline(&canvas, line, kMatchedLineColour, thickness);
  return canvas;
}

void drawOverlayLegend(cv::Mat* canvas, bool with_unmatched, bool with_hidden)
{
  struct Entry
  {
    cv::Scalar colour;
    std::string text;
    bool thin_dashed;
  };
  std::vector<Entry> entries = {
      {kMapLineColour, with_hidden ? "map lines on an image edge" : "map lines through the calibration", false}};
  if (with_hidden)
    entries.push_back({kMapLineColour, "map lines with no image edge (hidden or faint)", true});
  entries.push_back({kMatchedLineColour, "matched image lines", false});
  if (with_unmatched)
    entries.push_back({kUnmatchedLineColour, "unmatched image lines", false});
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
    const int dashes = entries[k].thin_dashed ? 4 : 1;
    for (int d = 0; d < dashes; ++d)  // a dashed sample: 4 dashes with gaps of their length
      cv::line(*canvas, cv::Point(box.x + pad + sample * 2 * d / (2 * dashes - 1), y),
               cv::Point(box.x + pad + sample * (2 * d + 1) / (2 * dashes - 1), y), entries[k].colour,
               entries[k].thin_dashed ? std::max(1, cvRound(scale)) : std::max(2, cvRound(3 * scale)), cv::LINE_AA);
    cv::putText(*canvas, entries[k].text, cv::Point(box.x + 2 * pad + sample, y + cvRound(6 * scale)), font,
                0.6 * scale, cv::Scalar(255, 255, 255), text_thickness, cv::LINE_AA);
  }
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
