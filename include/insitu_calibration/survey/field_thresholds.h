// The calibration node's thresholds that an operator tunes in the field: read from ROS parameters at start-up and
// changed while the node runs (dynamic_reconfigure, cfg/Calibration.cfg). One home for their names, ranges and
// defaults (the option structs' own); the .cfg repeats them for dynamic_reconfigure's tools, and
// test_calibration_parameters checks that the node's ~parameter_descriptions match this table.
#ifndef INSITU_CALIBRATION_SURVEY_FIELD_THRESHOLDS_H
#define INSITU_CALIBRATION_SURVEY_FIELD_THRESHOLDS_H

#include <string>
#include <vector>

#include "insitu_calibration/error.h"
#include "insitu_calibration/io/parameter_range.h"
#include "insitu_calibration/io/parameter_source.h"
#include "insitu_calibration/survey/camera_verification.h"
#include "insitu_calibration/survey/fixed_camera.h"

namespace insitu_calibration
{
struct FieldThresholds
{
  // The fixed cameras' options: the sanity checks of a result (max_rms_px, min_matched_lines, focal ratios) and
  // RANSAC's inlier threshold are tuned here; the rest is set once at start-up.
  FixedCameraOptions cameras;
  CameraVerificationOptions watchdog;  // the moved-camera watchdog's thresholds
  double verify_period_s = 60.0;       // the watchdog's period; 0: only on ~verify
  // /diagnostics: a camera whose last image is older is stale; a calibration more uncertain is reported (WARN).
  double stale_image_s = 10.0;
  double max_sigma_position_m = 0.05;
  double max_sigma_rotation_deg = 0.5;
};

struct FieldThreshold
{
  std::string parameter;         // the ROS parameter, in the node's private namespace: "watchdog/max_rotation_deg"
  std::string reconfigure_name;  // its dynamic_reconfigure name (an identifier): "watchdog_max_rotation_deg"
  ParameterRange range;
  double (*get)(const FieldThresholds&);
  void (*set)(FieldThresholds&, double);
};

// Every field-tuned threshold, in the .cfg's order.
const std::vector<FieldThreshold>& fieldThresholds();
// The threshold of a dynamic_reconfigure name; nullptr when there is none.
const FieldThreshold* findFieldThreshold(const std::string& reconfigure_name);
// What a range check alone cannot see: min_focal_ratio below max_focal_ratio. Errors name both parameters.
Status checkFieldThresholds(const FieldThresholds& thresholds);
// Every threshold of the table that source sets (its current value in thresholds is the default), then
// checkFieldThresholds; errors are collected in source.
void readFieldThresholds(ParameterSource& source, FieldThresholds& thresholds);
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_FIELD_THRESHOLDS_H
