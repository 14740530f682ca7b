// The 3D half for the robot's RGB-D camera: 2D segments in the RGB frame (fine-tuned on the gradient), depth along
// each on the near side of discontinuities, RANSAC + refinement into a 3D line, and the transform into the map
// frame with the frame's pose. Lines with too few inliers or too short are dropped (counted in the stats).
#ifndef INSITU_CALIBRATION_LINES_RGBD_LINES_H
#define INSITU_CALIBRATION_LINES_RGBD_LINES_H

#include <optional>
#include <string>
#include <vector>

#include "insitu_calibration/error.h"
#include "insitu_calibration/lines/depth_sampler.h"
#include "insitu_calibration/lines/gradient_refiner.h"
#include "insitu_calibration/lines/line3d_fitter.h"
#include "insitu_calibration/lines/rgbd_frame.h"
#include "insitu_calibration/lines/segment_detector.h"

namespace insitu_calibration
{
struct RgbdLineOptions
{
  RgbdLineOptions();

  SegmentDetectorOptions detector;  // min_length_px 25 by default here
  bool refine_segments = true;      // fine-tune each RGB segment (Eq. 8) before sampling depth
  RefinerOptions refiner;           // extension_px 0 by default here: the depth is sampled on the segment only
  DepthSamplerOptions sampler;
  Line3dFitOptions fit;
  double min_range_m = 0.4;  // depth outside [min_range_m, max_range_m] is ignored (the Xtion: ~0.5 to ~6 m)
  double max_range_m = 6.0;
};

struct RgbdLineStats
{
  int segments = 0;        // detected in the RGB image
  int lines = 0;           // 3D lines returned
  int no_depth = 0;        // segments without enough depth samples
  int no_line = 0;         // RANSAC found no line with enough inliers
  int too_short = 0;       // inliers shorter than min_length_m
  double detect_ms = 0.0;  // times: CPU time of the calling thread (the cost on one core)
  double refine_ms = 0.0;  // 2D fine-tuning
  double depth_ms = 0.0;   // depth conversion and sampling
  double fit_ms = 0.0;     // RANSAC and refinement
  std::string note;        // why the result is empty, when it is
};

// A segment of the RGB image that did not become a 3D line, with the depth sampled along it (perhaps none): a
// candidate for lines placed on a known surface (map/floor_lines.h).
struct UnliftedSegment
{
  Segment2d segment;  // fine-tuned, distorted pixels
  std::vector<DepthSample> samples;
};

// Reusable extractor: keeps the detector between frames. Not thread-safe (one per thread).
class RgbdLineExtractor
{
public:
  explicit RgbdLineExtractor(const RgbdLineOptions& options = RgbdLineOptions());

  // 3D lines of one frame in the map frame (Line3d::range_m is the distance from the sensor, Line3d::image the RGB
  // segment). Errors (nothing is thrown): invalid frame (validateFrame: empty images, size mismatches, zero focal
  // length, depth neither 16UC1 nor 32FC1, bad pose) as kInvalidInput, depth without any valid pixel as
  // kNotEnoughData. A frame without usable lines gives an empty vector and stats->note says why.
  // unlifted (optional): the segments without a 3D line. segments (optional): every RGB segment it tried to lift
  // (detectSegments' result), for other uses of the frame's edges without detecting them again.
  Expected<std::vector<Line3d>> extract(const RgbdFrame& frame, RgbdLineStats* stats = nullptr,
                                        std::vector<UnliftedSegment>* unlifted = nullptr,
                                        std::vector<Segment2d>* segments = nullptr);

  // The RGB image's segments as extract() lifts them: detected, then fine-tuned (refine_segments). Errors: the
  // detector's or the refiner's. stats (optional): segments and times.
  Expected<std::vector<Segment2d>> detectSegments(const cv::Mat& rgb, RgbdLineStats* stats = nullptr) const;

  const RgbdLineOptions& options() const { return options_; }

private:
  // One segment's 3D line from the depth along it, in the map frame; none (counted in st) without one.
  std::optional<Line3d> liftSegment(const RgbdFrame& frame, const cv::Mat& depth_m, const Segment2d& segment,
                                    uint32_t seed, RgbdLineStats* st, std::vector<DepthSample>* samples_out) const;

  RgbdLineOptions options_;
  SegmentDetector detector_;
};

// One-shot convenience (builds the detector on every call).
Expected<std::vector<Line3d>> extractRgbdLines(const RgbdFrame& frame,
                                               const RgbdLineOptions& options = RgbdLineOptions(),
                                               RgbdLineStats* stats = nullptr);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_RGBD_LINES_H
