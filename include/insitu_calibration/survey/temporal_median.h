// The per-pixel median of a camera's recent images: people walking through a fixed camera's view are in few of
// them and vanish from the median, so they do not create lines.
#ifndef INSITU_CALIBRATION_SURVEY_TEMPORAL_MEDIAN_H
#define INSITU_CALIBRATION_SURVEY_TEMPORAL_MEDIAN_H

#include <deque>

#include <opencv2/core.hpp>

#include "insitu_calibration/error.h"

namespace insitu_calibration
{
class TemporalMedian
{
public:
  explicit TemporalMedian(size_t capacity = 15) : capacity_(capacity == 0 ? 1 : capacity) {}

  // Adds an 8-bit grey image (colour images are converted). Errors: empty image, a size other than the first
  // image's (the buffer keeps its images).
  Status add(const cv::Mat& image);
  size_t size() const { return images_.size(); }
  bool empty() const { return images_.empty(); }
  void clear() { images_.clear(); }
  // CV_8UC1 median of the buffered images (the lower median for an even count); empty when there is none.
  cv::Mat median() const;

private:
  size_t capacity_;
  std::deque<cv::Mat> images_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_TEMPORAL_MEDIAN_H
