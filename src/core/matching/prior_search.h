// Step 1 of the matcher: the cameras within the prior's uncertainty that best explain the image lines.
#ifndef INSITU_CALIBRATION_MATCHING_PRIOR_SEARCH_H
#define INSITU_CALIBRATION_MATCHING_PRIOR_SEARCH_H

#include <vector>

#include "matching_problem.h"  // beside this header: unit tests include it without src/core on their path

namespace insitu_calibration
{
namespace matching
{
// A grid over yaw, pitch and field of view within 1.5 sigma; the search_starts best distinct cells are then each
// refined by a pattern search over all seven values (repetitive structure such as a row of windows gives several
// local optima, and the best grid cell is not always the right one). With hypothesis_starts, the best hypotheses from
// line correspondences (hypotheses.h) follow, each refined by the same pattern search. With prior_start, the prior
// itself comes first.
std::vector<CameraModel> searchPrior(const MatchingProblem& problem, const CameraPrior& prior);
}  // namespace matching
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MATCHING_PRIOR_SEARCH_H
