#include "insitu_calibration/lines/image_lines.h"

#include <ctime>

namespace insitu_calibration
{
namespace
{
// CPU time of the calling thread, ms: what the work costs on one core, whatever else runs on the machine.
double threadCpuMs()
{
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}
double msSince(double t)
{
  return threadCpuMs() - t;
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

  double t = threadCpuMs();
  SegmentDetector detector(options.detector);
  auto segments = detector.detect(image);
  if (!segments)
    return segments.error();
  st.segments = std::move(*segments);
  st.detect_ms = msSince(t);

  t = threadCpuMs();
  const std::vector<ImagePolyline> polylines = mergeSegments(st.segments, distortion, options.merge);
  st.polylines = static_cast<int>(polylines.size());
  st.merge_ms = msSince(t);

  t = threadCpuMs();
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
      const int parts = static_cast<int>(refined->parts.size());
      if (parts - refined->failed_parts < options.min_part_support * parts)
      {
        ++st.rejected;
        continue;
      }
      // Pieces between the vertices where two fine-tuned parts disagree.
      std::vector<size_t> cuts = {0};
      for (size_t k = 1; k < refined->parts.size(); ++k)
      {
        const RefinedSegment& before = refined->parts[k - 1];
        const RefinedSegment& after = refined->parts[k];
        if (options.split_gap_px > 0.0 && before.samples > 0 && after.samples > 0 &&
            (before.b - after.a).norm() > options.split_gap_px)
          cuts.push_back(k);
      }
      cuts.push_back(refined->parts.size());
      st.splits += cuts.size() > 2;
      for (size_t c = 0; c + 1 < cuts.size(); ++c)
      {
        const size_t first = cuts[c], last = cuts[c + 1];  // parts [first, last), vertices [first, last]
        ImageLine line;
        line.detected.assign(polyline.points.begin() + first, polyline.points.begin() + last + 1);
        line.points.assign(refined->points.begin() + first, refined->points.begin() + last + 1);
        line.parts.assign(refined->parts.begin() + first, refined->parts.begin() + last);
        line.fragments = polyline.fragments;
        // A cut vertex belongs to the part on its side only.
        if (c > 0)
          line.points.front() = line.parts.front().a;
        if (c + 2 < cuts.size())
          line.points.back() = line.parts.back().b;
        trimFailedEnds(line);
        if (line.points.size() < 2)
        {
          ++st.rejected;
          continue;
        }
        line.length_px = polyline.length_px;
        if (cuts.size() > 2)
        {
          line.length_px = 0.0;
          for (size_t k = 0; k + 1 < line.points.size(); ++k)
            line.length_px += (line.points[k + 1] - line.points[k]).norm();
        }
        if (cuts.size() > 2 && line.length_px < options.merge.min_length_px)
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
