#include "insitu_calibration/lines/image_lines.h"

#include <chrono>

namespace insitu_calibration
{
namespace
{
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// Drops failed parts at the two ends of a refined polyline (the edge is shorter than the detection there).
void trimFailedEnds(ImageLine& line)
{
  while (!line.parts.empty() && line.parts.front().samples == 0)
  {
    line.parts.erase(line.parts.begin());
    line.points.erase(line.points.begin());
  }
  while (!line.parts.empty() && line.parts.back().samples == 0)
  {
    line.parts.pop_back();
    line.points.pop_back();
  }
}

}  // namespace

Expected<std::vector<ImageLine>> extractImageLines(const cv::Mat& image, const DivisionModel& distortion,
                                                   const ImageLineOptions& options, ImageLineStats* stats)
{
  ImageLineStats local;
  ImageLineStats& st = stats ? *stats : local;
  st = ImageLineStats();
  if (image.empty())
    return Error(ErrorCode::kInvalidInput, "the image is empty");
  if (!std::isfinite(distortion.lambda) || !distortion.center.allFinite())
    return Error(ErrorCode::kInvalidInput, "the distortion model is not finite");

  auto t = Clock::now();
  SegmentDetector detector(options.detector);
  auto segments = detector.detect(image);
  if (!segments)
    return segments.error();
  st.segments = std::move(*segments);
  st.detect_ms = msSince(t);

  t = Clock::now();
  const std::vector<ImagePolyline> polylines = mergeSegments(st.segments, distortion, options.merge);
  st.polylines = static_cast<int>(polylines.size());
  st.merge_ms = msSince(t);

  t = Clock::now();
  std::vector<ImageLine> lines;
  if (!polylines.empty())
  {
    auto refiner = LineRefiner::create(image, options.refiner);
    if (!refiner)
      return refiner.error();
    for (const auto& polyline : polylines)
    {
      auto refined = refiner->refinePolyline(polyline.points);
      if (!refined)
      {
        ++st.rejected;
        continue;
      }
      ImageLine line;
      line.detected = polyline.points;
      line.points = refined->points;
      line.parts = refined->parts;
      line.fragments = polyline.fragments;
      line.length_px = polyline.length_px;
      const int parts = static_cast<int>(line.parts.size());
      if (parts - refined->failed_parts < options.min_part_support * parts)
      {
        ++st.rejected;
        continue;
      }
      trimFailedEnds(line);
      if (line.points.size() < 2)
      {
        ++st.rejected;
        continue;
      }
      double contrast = 0.0;
      int ok_parts = 0;
      for (const auto& p : line.parts)
        if (p.samples > 0)
        {
          contrast += p.contrast;
          ++ok_parts;
        }
      line.contrast = ok_parts ? contrast / ok_parts : 0.0;
      lines.push_back(std::move(line));
    }
  }
  st.refine_ms = msSince(t);
  st.lines = static_cast<int>(lines.size());
  if (lines.empty())
  {
    if (st.segments.empty())
      st.note = "no line segment of at least " + std::to_string(options.detector.min_length_px) + " px detected";
    else if (polylines.empty())
      st.note = std::to_string(st.segments.size()) + " segments, but no merged line of at least " +
                std::to_string(options.merge.min_length_px) + " px";
    else
      st.note = "fine-tuning found no edge under any of the " + std::to_string(polylines.size()) + " lines";
  }
  return lines;
}

Expected<std::vector<ImageLine>> extractImageLines(const cv::Mat& image, const CameraModel& camera,
                                                   const ImageLineOptions& options, ImageLineStats* stats)
{
  return extractImageLines(image, camera.distortion(), options, stats);
}

double refineImageLines(const LineRefiner& refiner, std::vector<ImageLine>& lines)
{
  double max_shift = 0.0;
  for (auto& line : lines)
  {
    auto refined = refiner.refinePolyline(line.points);
    if (!refined)
      continue;
    line.points = refined->points;
    line.parts = refined->parts;
    max_shift = std::max(max_shift, refined->max_shift_px);
  }
  return max_shift;
}

}  // namespace insitu_calibration
