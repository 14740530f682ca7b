// One camera's matching problem as the matcher's steps share it: the map, the image lines (raw and summarised),
// the image size and the options. A view: it refers to the caller's data, which must outlive it.
#ifndef INSITU_CALIBRATION_MATCHING_MATCHING_PROBLEM_H
#define INSITU_CALIBRATION_MATCHING_MATCHING_PROBLEM_H

#include <set>
#include <utility>
#include <vector>

#include "insitu_calibration/matching/line_matcher.h"
#include "line_projection.h"  // beside this header: unit tests include it without src/core on their path

namespace insitu_calibration
{
namespace matching
{
using PairSet = std::set<std::pair<size_t, size_t>>;  // (image line, map line) pairs

struct MatchingProblem
{
  MatchingProblem(const std::vector<Segment3d>& map_lines_, const std::vector<double>& map_sigmas_,
                  const std::vector<std::vector<Eigen::Vector2d>>& image_lines_, int width_, int height_,
                  const LineMatcherOptions& options_)
      : map_lines(map_lines_),
        map_sigmas(map_sigmas_),
        image_lines(image_lines_),
        image(summarizeImageLines(image_lines_)),
        width(width_),
        height(height_),
        options(options_)
  {}
  const std::vector<Segment3d>& map_lines;
  const std::vector<double>& map_sigmas;  // per map line, m (may be empty)
  const std::vector<std::vector<Eigen::Vector2d>>& image_lines;
  const std::vector<ImageChord> image;  // image_lines summarised
  const int width;
  const int height;
  const LineMatcherOptions& options;
  // With a prior (matchAndCalibrate's, outliving the problem): results beyondPriorDistance of it by
  // options.max_prior_distance_sigmas rank last.
  const CameraPrior* prior = nullptr;
  // Per image line, m (may be empty): added to its match's map line sigma (matchAndCalibrate's
  // image_line_world_sigmas_m, outliving the problem).
  const std::vector<double>* image_world_sigmas = nullptr;
  // Per map line, m: the sigmas of the chosen result's final calibration and its uncertainty, where they differ from
  // the search's (matchAndCalibrate's final_map_line_sigmas_m); used only with one entry per map line.
  const std::vector<double>* final_map_sigmas = nullptr;
};

// The explanation score (below) plus kFarFromPriorPenalty when the camera is beyond the problem's prior distance:
// what the matcher ranks its results by.
constexpr double kFarFromPriorPenalty = 1e6;
double rankingScore(const CameraModel& camera, const MatchingProblem& problem);

// How badly a camera explains the image lines for the prior search: each line's distance to its nearest compatible
// projection (2 samples), capped at cap_px, summed.
double searchScore(const CameraModel& camera, const MatchingProblem& problem, double max_angle_deg, double cap_px);

// How well a camera explains the image lines: the sum over image lines of the squared mean distance to the nearest
// compatible projected 3D line (through the division model), capped at explanation_cap_px^2. Lower is better.
double explanationScore(const CameraModel& camera, const MatchingProblem& problem);

// Matches under a camera (each image line and each map line used once), leaving out the banned pairs.
std::vector<LineMatch> matchLinesExcept(const MatchingProblem& problem, const CameraModel& camera, double max_angle_deg,
                                        double max_distance_px, const PairSet& banned);
}  // namespace matching
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MATCHING_MATCHING_PROBLEM_H
