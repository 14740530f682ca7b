#include "insitu_calibration/survey/keyframe_selector.h"

#include <cmath>

namespace insitu_calibration
{
bool KeyframeSelector::accept(const Eigen::Isometry3d& pose, double stamp)
{
  if (last_)
  {
    const Eigen::Isometry3d delta = last_->first.inverse() * pose;
    const double angle_deg = Eigen::AngleAxisd(delta.linear()).angle() * 180.0 / M_PI;
    const bool moved = delta.translation().norm() >= options_.min_translation_m;
    const bool turned = angle_deg >= options_.min_rotation_deg;
    const bool timed_out = options_.max_interval_s > 0.0 && stamp - last_->second >= options_.max_interval_s;
    // A clock that jumped back (bag restarted) starts over.
    if (!moved && !turned && !timed_out && stamp >= last_->second)
      return false;
  }
  last_ = std::make_pair(pose, stamp);
  return true;
}

}  // namespace insitu_calibration
