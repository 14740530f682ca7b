// The matcher's local moves around its current best result (see matchFromStarts in line_matcher.cpp): basin
// hopping and the influence check.
#ifndef INSITU_CALIBRATION_MATCHING_LOCAL_MOVES_H
#define INSITU_CALIBRATION_MATCHING_LOCAL_MOVES_H

#include "matching/matching_problem.h"

namespace insitu_calibration
{
namespace matching
{
// The current best result, its explanation score and the matches banned on the way to it.
struct Incumbent
{
  LineMatchResult result;
  double score;
  PairSet banned;
};

void traceResult(const LineMatcherOptions& options, const char* what, const LineMatchResult& r, double score);

// Basin hopping: the result of a start can be a wrong local optimum next to the right one (a camera a little
// farther with a longer focal length, or shifted along a repeated structure, matches most lines). The camera is
// moved by the typical size of such errors (hopCameras) and the matching redone from each. True when one explains
// the image better by more than min_score_gain (it becomes the incumbent).
bool hopRound(const MatchingProblem& problem, Incumbent* best);

// Influence check: a wrong match with enough leverage pulls the camera onto itself; its own residual is small, the
// others' grow a little. Its influence (how far the camera moves without it) gives it away: the most influential
// matches are each banned in turn and the matching redone from the current camera. True when that helped.
bool influenceRound(const MatchingProblem& problem, Incumbent* best);
}  // namespace matching
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MATCHING_LOCAL_MOVES_H
