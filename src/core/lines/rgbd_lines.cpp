#include "insitu_calibration/lines/rgbd_lines.h"

#include "insitu_calibration/cpu_time.h"
#include "insitu_calibration/io/parameter_range.h"

namespace insitu_calibration
{
RgbdLineOptions::RgbdLineOptions()
{
  detector.min_length_px = 25.0;
  refiner.extension_px = 0.0;
  refiner.search_px = 1.5;
  // No break test or off-line ends: the segments are not split or trimmed here, and the break test's re-fits left the
  // 3D lines the same or slightly worse on the simulator (within 3 m median 1.07 vs 1.06 mm, 0.189 vs 0.188 deg).
  refiner.end_tolerance_px = 0.0;
}

RgbdLineExtractor::RgbdLineExtractor(const RgbdLineOptions& options) : options_(options), detector_(options.detector) {}

namespace
{
// Each segment's ends refined on the image gradient (kept as detected where the refinement fails).
Status refineSegments(const cv::Mat& rgb, const RefinerOptions& options, std::vector<Segment2d>* segments)
{
  auto refiner = LineRefiner::create(rgb, options);
  if (!refiner)
    return refiner.error();
  for (auto& s : *segments)
  {
    auto refined = refiner->refineSegment(s.a, s.b);
    if (refined)
    {
      s.a = refined->a;
      s.b = refined->b;
    }
  }
  return Success{};
}

// Why a frame gave no 3D line, for the stats' note.
std::string noLineNote(const RgbdLineStats& st, double min_length_px)
{
  if (st.segments == 0)
    return "no line segment of at least " + formatParameterValue(min_length_px) + " px in the RGB image";
  return std::to_string(st.segments) + " segments, none became a 3D line (" + std::to_string(st.no_depth) +
         " without depth, " + std::to_string(st.no_line) + " without a consensus, " + std::to_string(st.too_short) +
         " too short)";
}
}  // namespace

std::optional<Line3d> RgbdLineExtractor::liftSegment(const RgbdFrame& frame, const cv::Mat& depth_m,
                                                     const Segment2d& segment, uint32_t seed, RgbdLineStats* st,
                                                     std::vector<DepthSample>* samples_out) const
{
  double t = threadCpuMs();
  std::vector<DepthSample>& samples = *samples_out;
  samples = sampleDepthAlongSegment(depth_m, segment, options_.sampler);
  st->depth_ms += cpuMsSince(t);
  Line3dFitOptions fit = options_.fit;
  if (samples.size() < static_cast<size_t>(std::max(2, fit.min_inliers)))
  {
    ++st->no_depth;
    return std::nullopt;
  }
  t = threadCpuMs();
  fit.seed = seed;
  fit.registration_sigma_px = options_.sampler.registration_sigma_px;
  auto line = fitLine3dToDepthSamples(segment, samples, frame.camera, fit);
  st->fit_ms += cpuMsSince(t);
  if (!line)
  {
    if (line.error().code() == ErrorCode::kDegenerate)
      ++st->too_short;
    else if (line.error().code() == ErrorCode::kNotEnoughData)
      ++st->no_depth;
    else
      ++st->no_line;
    return std::nullopt;
  }
  line->transform(frame.T_map_camera);
  line->sensor = frame.T_map_camera.translation();
  line->stamp = frame.stamp;
  return *line;
}

Expected<std::vector<Segment2d>> RgbdLineExtractor::detectSegments(const cv::Mat& rgb, RgbdLineStats* stats) const
{
  RgbdLineStats local;
  RgbdLineStats& st = stats ? *stats : local;
  double t = threadCpuMs();
  auto segments = detector_.detect(rgb);
  if (!segments)
    return segments.error();
  st.segments = static_cast<int>(segments->size());
  st.detect_ms = cpuMsSince(t);
  if (options_.refine_segments && !segments->empty())
  {
    t = threadCpuMs();
    if (const Status refined = refineSegments(rgb, options_.refiner, &*segments); !refined)
      return refined.error();
    st.refine_ms = cpuMsSince(t);
  }
  return segments;
}

Expected<std::vector<Line3d>> RgbdLineExtractor::extract(const RgbdFrame& frame, RgbdLineStats* stats,
                                                         std::vector<UnliftedSegment>* unlifted,
                                                         std::vector<Segment2d>* segments_out)
{
  RgbdLineStats local;
  RgbdLineStats& st = stats ? *stats : local;
  st = RgbdLineStats();
  if (auto s = validateFrame(frame); !s)
    return s.error();

  double t = threadCpuMs();
  auto depth = depthToMeters(frame.depth, options_.min_range_m, options_.max_range_m);
  if (!depth)
    return depth.error();
  st.depth_ms += cpuMsSince(t);

  auto segments = detectSegments(frame.rgb, &st);
  if (!segments)
    return segments.error();

  std::vector<Line3d> lines;
  if (unlifted)
    unlifted->clear();
  for (size_t i = 0; i < segments->size(); ++i)
  {
    std::vector<DepthSample> samples;
    if (auto line =
            liftSegment(frame, *depth, (*segments)[i], options_.fit.seed + static_cast<uint32_t>(i), &st, &samples))
      lines.push_back(*line);
    else if (unlifted)
      unlifted->push_back({(*segments)[i], std::move(samples)});
  }
  st.lines = static_cast<int>(lines.size());
  if (lines.empty())
    st.note = noLineNote(st, options_.detector.min_length_px);
  if (segments_out)
    *segments_out = std::move(*segments);
  return lines;
}

Expected<std::vector<Line3d>> extractRgbdLines(const RgbdFrame& frame, const RgbdLineOptions& options,
                                               RgbdLineStats* stats)
{
  RgbdLineExtractor extractor(options);
  return extractor.extract(frame, stats);
}

}  // namespace insitu_calibration
