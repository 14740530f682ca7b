// Step 3 of the matcher from one start camera: match, calibrate, re-match with tightened thresholds until the
// matches settle; and the correspondences a set of matches makes.
#ifndef INSITU_CALIBRATION_MATCHING_MATCH_REFINEMENT_H
#define INSITU_CALIBRATION_MATCHING_MATCH_REFINEMENT_H

#include <limits>
#include <vector>

#include "matching/matching_problem.h"

namespace insitu_calibration
{
namespace matching
{
// From `start`, with a first distance threshold of initial_max_distance_px, never matching the banned pairs. A start
// whose calibration still explains the image worse than abandon_above after options.abandon_after rounds is
// abandoned (an error).
Expected<LineMatchResult> refineMatches(const MatchingProblem& problem, const CameraModel& start,
                                        double initial_max_distance_px, const PairSet& banned,
                                        double abandon_above = std::numeric_limits<double>::infinity());

// A match's world sigma (LineCorrespondence::world_sigma_m): its map line's from map_sigmas (none: 0) and its image
// line's from the problem's image_world_sigmas, in quadrature.
double worldSigmaOf(const LineMatch& match, const MatchingProblem& problem, const std::vector<double>& map_sigmas);

// The image lines left unmatched are straight edges too (plumb lines for the distortion), when they have 3 or more
// points and a chord of at least min_length_px (0: none).
// taken: image lines used otherwise (direction lines), none when empty.
std::vector<std::vector<Eigen::Vector2d>> straightLinesOf(const std::vector<LineMatch>& matches,
                                                          const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                                          double min_length_px, const std::vector<bool>& taken = {});

}  // namespace matching
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MATCHING_MATCH_REFINEMENT_H
