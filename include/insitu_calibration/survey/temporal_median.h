// The per-pixel median of a camera's recent images: people walking through a fixed camera's view are in few of
// them and vanish from the median, so they do not create lines.
#ifndef INSITU_CALIBRATION_SURVEY_TEMPORAL_MEDIAN_H
#define INSITU_CALIBRATION_SURVEY_TEMPORAL_MEDIAN_H

#include <deque>
#include <memory>
#include <mutex>

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
  // CV_8UC1 median of the buffered images (the lower median for an even count); empty when there is none. Computed
  // once per set of images (copies of this buffer share the result); thread-safe between copies.
  cv::Mat median() const;

private:
  // The last median and the buffer it came from (its first and last image and their number: every image is a
  // fresh copy held here, so these name the set). Shared by copies: the node's snapshots of a camera ask for the
  // median of the same images for ~status, the status topic and each step of a calibration, and the median of 40
  // full-HD images takes seconds.
  struct MedianCache
  {
    std::mutex mutex;
    cv::Mat first, last;
    size_t count = 0;
    cv::Mat median;
  };
  cv::Mat computeMedian() const;

  size_t capacity_;
  std::deque<cv::Mat> images_;
  std::shared_ptr<MedianCache> cache_ = std::make_shared<MedianCache>();
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_TEMPORAL_MEDIAN_H
