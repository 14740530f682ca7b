// The survey's tunable options as named parameters: calibration_node's private ROS parameters and the same names in
// calibrate_survey's parameter file (--params, by default its --cameras file, which the node loads as its
// parameters too). One reader for both, so a name, its default (the option structs') and its range exist once.
#ifndef INSITU_CALIBRATION_SURVEY_SURVEY_PARAMETERS_H
#define INSITU_CALIBRATION_SURVEY_SURVEY_PARAMETERS_H

#include "insitu_calibration/io/parameter_source.h"
#include "insitu_calibration/survey/survey.h"

namespace insitu_calibration
{
// options with every parameter that source sets; errors (wrong type, out of range, min_focal_ratio not below
// max_focal_ratio) are collected in source.
SurveyOptions readSurveyParameters(ParameterSource& source, SurveyOptions options = {});
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_SURVEY_PARAMETERS_H
