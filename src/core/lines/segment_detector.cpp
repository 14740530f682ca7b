#include "insitu_calibration/lines/segment_detector.h"

#include <cmath>

#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc/fast_line_detector.hpp>

namespace insitu_calibration
{
const char* toString(SegmentDetectorKind kind)
{
  switch (kind)
  {
    case SegmentDetectorKind::kFastLineDetector:
      return "fld";
    case SegmentDetectorKind::kLsd:
      return "lsd";
  }
  return "unknown";
}

std::optional<SegmentDetectorKind> parseSegmentDetectorKind(const std::string& name)
{
  if (name == "fld")
    return SegmentDetectorKind::kFastLineDetector;
  if (name == "lsd")
    return SegmentDetectorKind::kLsd;
  return std::nullopt;
}

Expected<cv::Mat> toGray8(const cv::Mat& image)
{
  if (image.empty())
    return Error(ErrorCode::kInvalidInput, "the image is empty");
  try
  {
    cv::Mat gray;
    switch (image.type())
    {
      case CV_8UC1:
        return image;
      case CV_8UC3:
        cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
        return gray;
      case CV_8UC4:
        cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
        return gray;
      case CV_16UC1:
        image.convertTo(gray, CV_8U, 1.0 / 257.0);
        return gray;
      case CV_32FC1: {
        double max_value = 0.0;
        cv::minMaxLoc(image, nullptr, &max_value);
        image.convertTo(gray, CV_8U, max_value <= 1.0 ? 255.0 : 1.0);
        return gray;
      }
      default:
        return Error(ErrorCode::kInvalidInput, "unsupported image type " + cv::typeToString(image.type()) +
                                                   " (expected 8UC1, 8UC3, 8UC4, 16UC1 or 32FC1)");
    }
  }
  catch (const cv::Exception& e)
  {
    return Error(ErrorCode::kInvalidInput, std::string("OpenCV could not convert the image: ") + e.what());
  }
}

struct SegmentDetector::Impl
{
  cv::Ptr<cv::ximgproc::FastLineDetector> fld;
  cv::Ptr<cv::LineSegmentDetector> lsd;
};

SegmentDetector::SegmentDetector(const SegmentDetectorOptions& options) : options_(options), impl_(new Impl) {}

SegmentDetector::~SegmentDetector() = default;
SegmentDetector::SegmentDetector(SegmentDetector&&) noexcept = default;
SegmentDetector& SegmentDetector::operator=(SegmentDetector&&) noexcept = default;

Expected<std::vector<Segment2d>> SegmentDetector::detect(const cv::Mat& image) const
{
  auto gray = toGray8(image);
  if (!gray)
    return gray.error();
  std::vector<cv::Vec4f> raw;
  try
  {
    if (options_.kind == SegmentDetectorKind::kFastLineDetector)
    {
      if (!impl_->fld)
      {
        // The detector's own length filter works on integers; ours below is exact.
        impl_->fld = cv::ximgproc::createFastLineDetector(
            std::max(1, static_cast<int>(std::floor(options_.min_length_px))),
            static_cast<float>(options_.fld_distance_threshold_px), options_.fld_canny_low, options_.fld_canny_high,
            options_.fld_canny_aperture, false);
      }
      impl_->fld->detect(*gray, raw);
    }
    else
    {
      if (!impl_->lsd)
      {
        impl_->lsd = cv::createLineSegmentDetector(cv::LSD_REFINE_STD, options_.lsd_scale, options_.lsd_sigma_scale,
                                                   options_.lsd_quant, options_.lsd_angle_tolerance_deg);
      }
      impl_->lsd->detect(*gray, raw);
    }
  }
  catch (const cv::Exception& e)
  {
    return Error(ErrorCode::kNoSolution,
                 std::string("the ") + toString(options_.kind) + " line detector failed: " + e.what());
  }
  std::vector<Segment2d> segments;
  segments.reserve(raw.size());
  for (const auto& r : raw)
  {
    Segment2d s;
    s.a = Eigen::Vector2d(r[0], r[1]);
    s.b = Eigen::Vector2d(r[2], r[3]);
    if (s.a.allFinite() && s.b.allFinite() && s.length() >= options_.min_length_px)
      segments.push_back(s);
  }
  return segments;
}

}  // namespace insitu_calibration
