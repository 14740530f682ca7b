#include "insitu_calibration/survey/temporal_median.h"

#include <algorithm>
#include <mutex>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace insitu_calibration
{
Status TemporalMedian::add(const cv::Mat& image)
{
  if (image.empty())
    return Error(ErrorCode::kInvalidInput, "empty image");
  cv::Mat gray;
  if (image.channels() == 3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 4)
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  else
    gray = image;
  if (gray.depth() != CV_8U)
  {
    cv::Mat converted;
    double lo = 0.0, hi = 0.0;
    cv::minMaxLoc(gray, &lo, &hi);
    gray.convertTo(converted, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0, hi > lo ? -lo * 255.0 / (hi - lo) : 0.0);
    gray = converted;
  }
  if (!images_.empty() && gray.size() != images_.front().size())
    return Error(ErrorCode::kInvalidInput, "image size " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                                               " differs from the buffered images' " +
                                               std::to_string(images_.front().cols) + "x" +
                                               std::to_string(images_.front().rows));
  images_.push_back(gray.clone());
  while (images_.size() > capacity_)
    images_.pop_front();
  return Success{};
}

cv::Mat TemporalMedian::median() const
{
  if (images_.empty())
    return cv::Mat();
  if (!cache_)  // moved from
    return computeMedian();
  {
    std::lock_guard<std::mutex> lock(cache_->mutex);
    if (cache_->count == images_.size() && cache_->first.data == images_.front().data &&
        cache_->last.data == images_.back().data)
      return cache_->median.clone();  // a copy: callers may draw on it
  }
  cv::Mat out = computeMedian();  // without the lock: another copy's different images need not wait
  std::lock_guard<std::mutex> lock(cache_->mutex);
  cache_->first = images_.front();
  cache_->last = images_.back();
  cache_->count = images_.size();
  cache_->median = out.clone();
  return out;
}

cv::Mat TemporalMedian::computeMedian() const
{
  if (images_.size() == 1)
    return images_.front().clone();
  const cv::Mat& first = images_.front();
  cv::Mat out(first.size(), CV_8UC1);
  const size_t n = images_.size();
  const size_t mid = (n - 1) / 2;
  std::vector<uint8_t> values(n);
  for (int y = 0; y < first.rows; ++y)
  {
    std::vector<const uint8_t*> rows(n);
    for (size_t k = 0; k < n; ++k)
      rows[k] = images_[k].ptr<uint8_t>(y);
    uint8_t* dst = out.ptr<uint8_t>(y);
    for (int x = 0; x < first.cols; ++x)
    {
      for (size_t k = 0; k < n; ++k)
        values[k] = rows[k][x];
      std::nth_element(values.begin(), values.begin() + mid, values.end());
      dst[x] = values[mid];
    }
  }
  return out;
}

}  // namespace insitu_calibration
