// Time stamps for device frames: maps the device clock (microseconds since the device started) to host time and,
// when colour and depth are synchronised, gives the two frames of a pair exactly the same stamp.
#ifndef INSITU_CALIBRATION_DRIVERS_FRAME_STAMPER_H
#define INSITU_CALIBRATION_DRIVERS_FRAME_STAMPER_H

#include <cstdint>

#include "insitu_calibration/drivers/openni_device.h"

namespace insitu_calibration
{
namespace drivers
{
class FrameStamper
{
public:
  // paired: give colour/depth frames whose device times differ by at most half a frame period (at `fps`) one stamp:
  // the later frame of a pair takes the stamp of the earlier one (which may be a few frames back).
  // max_drift: how fast (s/s) the estimated offset may grow between two clocks that drift apart.
  // jump_s: a device clock that jumps by more than this (a recording looping, a device coming back) starts afresh.
  explicit FrameStamper(bool paired = true, int fps = 30, double max_drift = 1e-4, double jump_s = 1.0);

  // device_us: the frame's device time; host_now_s: host time when it was read. Returns the frame's host time: its
  // device time plus the smallest offset (host - device) seen, which removes the transfer latency's jitter.
  double stamp(StreamKind kind, uint64_t device_us, double host_now_s);
  void reset();

private:
  bool paired_;
  uint64_t pair_tolerance_us_;
  double max_drift_;
  double jump_s_;

  bool has_offset_ = false;
  double offset_s_ = 0.0;
  double last_host_s_ = 0.0;

  struct Last
  {
    bool valid = false;
    uint64_t device_us = 0;
    double stamp_s = 0.0;
  };
  static constexpr int kHistory = 4;
  Last history_[2][kHistory];  // the last frames of each stream, newest at next_[s] - 1
  int next_[2] = {0, 0};
};

}  // namespace drivers
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_DRIVERS_FRAME_STAMPER_H
