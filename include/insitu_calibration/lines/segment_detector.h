// 2D line segments in an image: OpenCV's LSD (von Gioi et al. 2012, cv::createLineSegmentDetector) or the ximgproc
// Fast Line Detector (Lee et al. 2014, cv::ximgproc::createFastLineDetector). The default is the FLD: on the
// rendered frames of bench_lines it is 13-14x faster than LSD (0.8 vs 10.8 ms at 640x480, 6.6 vs 95 ms at 1920x1080)
// at the same 2D accuracy after fine-tuning (0.053 vs 0.051 px RMS); docs/lines.md has the measurements.
//
// Pixel (0,0) is the centre of the top-left pixel (both detectors already use this convention).
#ifndef INSITU_CALIBRATION_LINES_SEGMENT_DETECTOR_H
#define INSITU_CALIBRATION_LINES_SEGMENT_DETECTOR_H

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "insitu_calibration/error.h"

namespace insitu_calibration
{
struct Segment2d
{
  Eigen::Vector2d a = Eigen::Vector2d::Zero();  // end points, px
  Eigen::Vector2d b = Eigen::Vector2d::Zero();

  double length() const { return (b - a).norm(); }
  Eigen::Vector2d direction() const { return (b - a).normalized(); }
};

enum class SegmentDetectorKind
{
  kFastLineDetector,  // ximgproc FLD: Canny edges + incremental line fitting
  kLsd,               // LSD: region growing on gradient angle with an a-contrario validation
};

const char* toString(SegmentDetectorKind kind);
// "fld" or "lsd" (case-sensitive); nullopt otherwise.
std::optional<SegmentDetectorKind> parseSegmentDetectorKind(const std::string& name);

struct SegmentDetectorOptions
{
  SegmentDetectorKind kind = SegmentDetectorKind::kFastLineDetector;
  double min_length_px = 20.0;  // shorter segments are dropped

  // FLD (grey levels of the 8-bit image for Canny).
  double fld_distance_threshold_px = 1.5;
  double fld_canny_low = 40.0;
  double fld_canny_high = 80.0;
  int fld_canny_aperture = 3;

  // LSD (OpenCV's defaults but for the length filter above).
  double lsd_scale = 0.8;
  double lsd_sigma_scale = 0.6;
  double lsd_quant = 2.0;
  double lsd_angle_tolerance_deg = 22.5;
};

// Converts any image the core accepts (8UC1, 8UC3 BGR, 8UC4 BGRA, 16UC1, 32FC1 in [0, 1] or [0, 255]) to 8-bit
// grey. Errors: empty image, unsupported type.
Expected<cv::Mat> toGray8(const cv::Mat& image);

// Reusable detector (build it once per stream: creating an OpenCV detector allocates). Not thread-safe: one
// instance per thread.
class SegmentDetector
{
public:
  explicit SegmentDetector(const SegmentDetectorOptions& options = SegmentDetectorOptions());
  ~SegmentDetector();
  SegmentDetector(SegmentDetector&&) noexcept;
  SegmentDetector& operator=(SegmentDetector&&) noexcept;

  // Segments at least min_length_px long. An image without lines gives an empty vector; errors only for bad input
  // (empty image, unsupported type) or an OpenCV failure (reported, never thrown).
  Expected<std::vector<Segment2d>> detect(const cv::Mat& image) const;

  const SegmentDetectorOptions& options() const { return options_; }

private:
  struct Impl;
  SegmentDetectorOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_SEGMENT_DETECTOR_H
