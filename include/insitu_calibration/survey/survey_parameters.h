// The survey's tunable options as named parameters: calibration_node's private ROS parameters and the same names in
// calibrate_survey's parameter file (--params, by default its --cameras file, which the node loads as its
// parameters too). One reader for both, so a name, its default (the option structs') and its range exist once.
#ifndef INSITU_CALIBRATION_SURVEY_SURVEY_PARAMETERS_H
#define INSITU_CALIBRATION_SURVEY_SURVEY_PARAMETERS_H

#include "insitu_calibration/io/parameter_source.h"
#include "insitu_calibration/survey/field_thresholds.h"
#include "insitu_calibration/survey/survey.h"

namespace insitu_calibration
{
// options with every parameter that source sets; errors (wrong type, out of range, min_focal_ratio not below
// max_focal_ratio) are collected in source. The thresholds tuned in the field (max_rms_px, ransac_threshold_px, ...)
// are read through their table (survey/field_thresholds.h), with the watchdog's and the diagnostics', which the node
// gets in *thresholds (the cameras' part of it is options.cameras).
SurveyOptions readSurveyParameters(ParameterSource& source, SurveyOptions options = {},
                                   FieldThresholds* thresholds = nullptr);
// Whether source gives the Xtion's depth registration (depth_registration/x_px or y_px): a sensor measured once,
// used as given. Otherwise calibrate_survey estimates it from the bag and the node from its keyframes.
bool depthRegistrationGiven(const ParameterSource& source);
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_SURVEY_PARAMETERS_H
