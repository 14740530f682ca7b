// Camera hypotheses from line correspondences, for a prior that is not close (docs/survey_calibration.md,
// "Hypotheses from line correspondences"): the grid of prior_search.cpp never moves the camera, so a prior 0.5 m off
// near the scene can leave it in the wrong basin. Here rotation and focal length come from image lines taken as
// vertical or as the map's dominant horizontal directions (the vertical-lines solver's first stage,
// solvers/vertical_lines_focal_pose.h), the centre from plane pairs of image and map lines under that rotation
// (linear, RANSAC), all within the prior's 3-sigma cone; the cameras are scored with the grid's score.
#ifndef INSITU_CALIBRATION_MATCHING_HYPOTHESES_H
#define INSITU_CALIBRATION_MATCHING_HYPOTHESES_H

#include <vector>

#include "matching_problem.h"  // beside this header: unit tests include it without src/core on their path

namespace insitu_calibration
{
namespace matching
{
// The options' hypothesis_starts best distinct hypotheses (fewer when fewer fall in the cone), best first.
// Deterministic (a fixed seed); at most hypothesis_iterations samples.
std::vector<CameraModel> lineHypotheses(const MatchingProblem& problem, const CameraPrior& prior);

// A prior centred on a camera (its position, axis, roll and field of view) with the given prior's uncertainties:
// the frame in which the prior search refines a hypothesis.
CameraPrior priorAt(const CameraModel& camera, int image_width, const CameraPrior& uncertainty);
}  // namespace matching
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MATCHING_HYPOTHESES_H
