#include "insitu_calibration/survey/overlay.h"

#include <algorithm>
#include <string>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/matching/line_matcher.h"

namespace insitu_calibration
{
namespace
{
cv::Point toPoint(const Eigen::Vector2d& m)
{
  return cv::Point(cvRound(m.x() * 16.0), cvRound(m.y() * 16.0));
}

void drawPolyline(cv::Mat* canvas, const std::vector<Eigen::Vector2d>& points, const cv::Scalar& colour, int thickness)
{
  for (size_t j = 1; j < points.size(); ++j)
    cv::line(*canvas, toPoint(points[j - 1]), toPoint(points[j]), colour, thickness, cv::LINE_AA, 4);
}

const cv::Scalar kMapColour(40, 40, 230);      // red (BGR)
const cv::Scalar kMatchedColour(60, 200, 60);  // green

// What the colours mean, in the top left corner on a dark box: the overlay is read without this README (in rviz's
// image panels, in the saved PNG). Sized to stay readable when rviz shrinks the image to a third of its width.
void drawLegend(cv::Mat* canvas)
{
  const double scale = std::max(0.5, canvas->cols / 1280.0);
  const int line_height = cvRound(30 * scale), margin = cvRound(8 * scale), sample = cvRound(40 * scale);
  const int thickness = std::max(1, cvRound(2 * scale));
  const std::vector<std::pair<std::string, cv::Scalar>> rows = {{"map lines through the calibration", kMapColour},
                                                                {"image lines matched to the map", kMatchedColour}};
  int text_width = 0;
  for (const auto& row : rows)
    text_width = std::max(text_width,
                          cv::getTextSize(row.first, cv::FONT_HERSHEY_SIMPLEX, 0.6 * scale, thickness, nullptr).width);
  const cv::Rect box(0, 0, std::min(canvas->cols, 3 * margin + sample + text_width),
                     std::min(canvas->rows, line_height * static_cast<int>(rows.size()) + margin));
  cv::Mat area = (*canvas)(box);
  area = area * 0.3;  // darkened, the image still faintly behind
  for (size_t i = 0; i < rows.size(); ++i)
  {
    const int y = margin + line_height * static_cast<int>(i) + line_height / 2;
    cv::line(*canvas, cv::Point(margin, y), cv::Point(margin + sample, y), rows[i].second, 2 * thickness, cv::LINE_AA);
    cv::putText(*canvas, rows[i].first, cv::Point(2 * margin + sample, y + cvRound(7 * scale)),
                cv::FONT_HERSHEY_SIMPLEX, 0.6 * scale, cv::Scalar(255, 255, 255), thickness, cv::LINE_AA);
  }
}
}  // namespace

cv::Mat drawOverlay(const cv::Mat& image, int width, int height, const CameraModel& camera,
                    const std::vector<Segment3d>& map_lines,
                    const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines)
{
  cv::Mat canvas;
  if (image.empty())
    canvas = cv::Mat(height, width, CV_8UC3, cv::Scalar(0, 0, 0));
  else if (image.channels() == 1)
    cv::cvtColor(image, canvas, cv::COLOR_GRAY2BGR);
  else
    canvas = image.clone();
  const int thickness = std::max(1, width / 640);
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
    drawPolyline(&canvas, curve, kMapColour, thickness);
  }
  for (const auto& line : matched_image_lines)
    drawPolyline(&canvas, line, kMatchedColour, thickness);
  drawLegend(&canvas);
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
