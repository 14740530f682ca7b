#include "insitu_calibration/simulation/line_frames.h"

#include <algorithm>

#include <opencv2/imgproc.hpp>

namespace insitu_calibration
{
namespace simulation
{
RgbdFrame toRgbdFrame(const SurveySimulator& survey, const XtionFrame& frame)
{
  const XtionConfig& xtion = survey.world().xtion;
  RgbdFrame out;
  out.rgb = toBgr(frame.rgb);
  out.depth = frame.depth_mm;
  out.camera.width = xtion.width;
  out.camera.height = xtion.height;
  out.camera.intrinsics = xtion.intrinsics;
  out.T_map_camera = frame.map_from_optical;
  out.stamp = 1e-9 * static_cast<double>(survey.options().start_time_ns + frame.stamp_ns);
  return out;
}

cv::Mat toBgr(const cv::Mat& rgb)
{
  if (rgb.empty() || rgb.type() != CV_8UC3)
    return rgb;
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  return bgr;
}

std::vector<Segment3d> toSegments(const std::vector<TrueEdge>& edges, const std::vector<std::string>& kinds)
{
  std::vector<Segment3d> out;
  out.reserve(edges.size());
  for (const auto& e : edges)
    if (kinds.empty() || std::find(kinds.begin(), kinds.end(), e.kind) != kinds.end())
      out.push_back({e.start, e.end});
  return out;
}

}  // namespace simulation
}  // namespace insitu_calibration
