#include "insitu_calibration/drivers/frame_stamper.h"

#include <algorithm>
#include <cmath>

namespace insitu_calibration
{
namespace drivers
{
FrameStamper::FrameStamper(bool paired, int fps, double max_drift, double jump_s)
    : paired_(paired),
      pair_tolerance_us_(static_cast<uint64_t>(500000.0 / std::max(fps, 1))),
      max_drift_(max_drift),
      jump_s_(jump_s)
{}

void FrameStamper::reset()
{
  has_offset_ = false;
  for (auto& stream : history_)
    for (Last& last : stream)
      last = Last();
}

double FrameStamper::stamp(StreamKind kind, uint64_t device_us, double host_now_s)
{
  const double device_s = static_cast<double>(device_us) * 1e-6;
  const double sample = host_now_s - device_s;  // offset + this frame's latency (>= 0)
  if (!has_offset_ || std::abs(sample - offset_s_) > jump_s_)
  {
    // First frame, or the device clock jumped (recording looped, device reset): start afresh.
    reset();
    has_offset_ = true;
    offset_s_ = sample;
  }
  else
  {
    // Let the offset creep up as fast as two clocks can drift apart, and take any smaller sample at once.
    offset_s_ += max_drift_ * std::max(0.0, host_now_s - last_host_s_);
    offset_s_ = std::min(offset_s_, sample);
  }
  last_host_s_ = host_now_s;

  double result = device_s + offset_s_;
  const int self = kind == StreamKind::kColor ? 0 : 1;
  if (paired_)
  {
    for (const Last& other : history_[1 - self])
    {
      const uint64_t diff = device_us > other.device_us ? device_us - other.device_us : other.device_us - device_us;
      if (other.valid && diff <= pair_tolerance_us_)
      {
        result = other.stamp_s;
        break;
      }
    }
  }
  history_[self][next_[self]] = Last{true, device_us, result};
  next_[self] = (next_[self] + 1) % kHistory;
  return result;
}

}  // namespace drivers
}  // namespace insitu_calibration
