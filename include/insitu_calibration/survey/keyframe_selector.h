// Keyframes by motion: a frame is kept when the sensor moved or turned enough since the last kept frame, so a robot
// standing still does not fill the line map with the same view.
#ifndef INSITU_CALIBRATION_SURVEY_KEYFRAME_SELECTOR_H
#define INSITU_CALIBRATION_SURVEY_KEYFRAME_SELECTOR_H

#include <optional>

#include <Eigen/Geometry>

namespace insitu_calibration
{
struct KeyframeOptions
{
  double min_translation_m = 0.10;
  double min_rotation_deg = 5.0;
  double max_interval_s = 0.0;  // also keep a frame after this long without one (0: never by time alone)
};

class KeyframeSelector
{
public:
  explicit KeyframeSelector(const KeyframeOptions& options = {}) : options_(options) {}

  // True (and the pose becomes the reference) when the frame is a keyframe.
  bool accept(const Eigen::Isometry3d& pose, double stamp);
  void reset() { last_.reset(); }

private:
  KeyframeOptions options_;
  std::optional<std::pair<Eigen::Isometry3d, double>> last_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_KEYFRAME_SELECTOR_H
