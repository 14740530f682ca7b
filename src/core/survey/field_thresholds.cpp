#include "insitu_calibration/survey/field_thresholds.h"

namespace insitu_calibration
{
namespace
{
using Range = ParameterRange;
using T = FieldThresholds;

// A size_t member through the table's double interface (the range makes it an integer first).
size_t toCount(double value)
{
  return static_cast<size_t>(value);
}
}  // namespace

const std::vector<FieldThreshold>& fieldThresholds()
{
  static const std::vector<FieldThreshold> table = {
      {"max_rms_px", "max_rms_px", Range::positive(100.0, "px"), [](const T& t) { return t.cameras.max_rms_px; },
       [](T& t, double v) { t.cameras.max_rms_px = v; }},
      {"ransac_threshold_px", "ransac_threshold_px", Range::positive(100.0, "px"),
       [](const T& t) { return t.cameras.matcher.calibration.ransac_options.inlier_threshold_px; },
       [](T& t, double v) { t.cameras.matcher.calibration.ransac_options.inlier_threshold_px = v; }},
      // Six lines at least: DLT-Lines' minimum.
      {"min_matched_lines", "min_matched_lines", Range::integers(6, 100000),
       [](const T& t) { return static_cast<double>(t.cameras.min_matched_lines); },
       [](T& t, double v) { t.cameras.min_matched_lines = toCount(v); }},
      {"min_focal_ratio", "min_focal_ratio", Range::positive(100.0),
       [](const T& t) { return t.cameras.min_focal_ratio; }, [](T& t, double v) { t.cameras.min_focal_ratio = v; }},
      {"max_focal_ratio", "max_focal_ratio", Range::positive(100.0),
       [](const T& t) { return t.cameras.max_focal_ratio; }, [](T& t, double v) { t.cameras.max_focal_ratio = v; }},
      {"verify_period_s", "verify_period_s", Range::closed(0.0, 86400.0, "s"),
       [](const T& t) { return t.verify_period_s; }, [](T& t, double v) { t.verify_period_s = v; }},
      {"watchdog/max_displacement_px", "watchdog_max_displacement_px", Range::positive(1000.0, "px"),
       [](const T& t) { return t.watchdog.max_displacement_px; },
       [](T& t, double v) { t.watchdog.max_displacement_px = v; }},
      {"watchdog/max_rotation_deg", "watchdog_max_rotation_deg", Range::positive(180.0, "deg"),
       [](const T& t) { return t.watchdog.max_rotation_deg; }, [](T& t, double v) { t.watchdog.max_rotation_deg = v; }},
      {"watchdog/sigma_factor", "watchdog_sigma_factor", Range::closed(0.0, 100.0),
       [](const T& t) { return t.watchdog.sigma_factor; }, [](T& t, double v) { t.watchdog.sigma_factor = v; }},
      {"watchdog/search_distance_px", "watchdog_search_distance_px", Range::positive(1000.0, "px"),
       [](const T& t) { return t.watchdog.search_distance_px; },
       [](T& t, double v) { t.watchdog.search_distance_px = v; }},
      {"watchdog/max_map_line_sigma", "watchdog_max_map_line_sigma", Range::closed(0.0, 1.0, "m"),
       [](const T& t) { return t.watchdog.max_map_line_sigma_m; },
       [](T& t, double v) { t.watchdog.max_map_line_sigma_m = v; }},
      {"watchdog/min_matched_lines", "watchdog_min_matched_lines", Range::integers(4, 100000),
       [](const T& t) { return static_cast<double>(t.watchdog.min_matched_lines); },
       [](T& t, double v) { t.watchdog.min_matched_lines = toCount(v); }},
      {"diagnostics/stale_image_s", "diagnostics_stale_image_s", Range::positive(86400.0, "s"),
       [](const T& t) { return t.stale_image_s; }, [](T& t, double v) { t.stale_image_s = v; }},
      {"diagnostics/max_sigma_position_m", "diagnostics_max_sigma_position_m", Range::positive(1000.0, "m"),
       [](const T& t) { return t.max_sigma_position_m; }, [](T& t, double v) { t.max_sigma_position_m = v; }},
      {"diagnostics/max_sigma_rotation_deg", "diagnostics_max_sigma_rotation_deg", Range::positive(180.0, "deg"),
       [](const T& t) { return t.max_sigma_rotation_deg; }, [](T& t, double v) { t.max_sigma_rotation_deg = v; }},
  };
  return table;
}

const FieldThreshold* findFieldThreshold(const std::string& reconfigure_name)
{
  for (const FieldThreshold& threshold : fieldThresholds())
    if (threshold.reconfigure_name == reconfigure_name)
      return &threshold;
  return nullptr;
}

Status checkFieldThresholds(const FieldThresholds& thresholds)
{
  const FixedCameraOptions& c = thresholds.cameras;
  if (c.min_focal_ratio >= c.max_focal_ratio)
    return Error(ErrorCode::kInvalidInput, "parameters ~min_focal_ratio (" + formatParameterValue(c.min_focal_ratio) +
                                               ") and ~max_focal_ratio (" + formatParameterValue(c.max_focal_ratio) +
                                               "): the minimum must be below the maximum");
  return Success{};
}

void readFieldThresholds(ParameterSource& source, FieldThresholds& thresholds)
{
  for (const FieldThreshold& threshold : fieldThresholds())
    threshold.set(thresholds, source.number(threshold.parameter, threshold.get(thresholds), threshold.range));
  if (const Status consistent = checkFieldThresholds(thresholds); !consistent)
    source.fail(consistent.error().message());
}
}  // namespace insitu_calibration
