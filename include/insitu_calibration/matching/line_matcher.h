// Finding which surveyed 3D lines a fixed camera sees as which of its image lines, from a rough prior of the camera
// (what an installer knows from the floor plan), and calibrating the camera on the way:
//  1. search the prior's uncertainty (yaw, pitch, field of view) for the camera that best explains the image lines
//     (each image line scored by its distance to the nearest compatible projected 3D line, capped);
//  2. match: project the 3D lines with the current camera, pair each image line with the 3D line of compatible angle,
//     small distance and overlapping extent (each 3D line used once);
//  3. calibrate on the matches robustly (RANSAC + DLT + refinement), re-project with the new camera, re-match with
//     thresholds tightened to the new residuals, and repeat until the matches stop changing.
#ifndef INSITU_CALIBRATION_MATCHING_LINE_MATCHER_H
#define INSITU_CALIBRATION_MATCHING_LINE_MATCHER_H

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "insitu_calibration/calibration.h"
#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/geometry/segment.h"

namespace insitu_calibration
{
// What is known of a fixed camera before calibration, with how uncertain it is.
struct CameraPrior
{
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // optical centre in the world, m
  double position_sigma_m = 0.5;
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // optical axis in the world (need not be unit)
  double direction_sigma_deg = 10.0;
  double roll_deg = 0.0;  // rotation about the optical axis; 0: the image x axis is horizontal (world z up)
  double horizontal_fov_deg = 60.0;
  double fov_sigma_relative = 0.2;
  // The principal point when it is known (a lab calibration of this camera), px, with its sigma per axis. In a narrow
  // view the lines hardly tell the principal point from the rotation (both shift the image); without it the
  // calibration assumes it within 3 % of the width of the image centre (LineMatcherOptions::calibration).
  std::optional<Eigen::Vector2d> principal_point;
  double principal_point_sigma_px = 5.0;
};

// Whether a camera centre lies more than max_sigmas position sigmas from the prior's position (the final check's
// limit, FixedCameraOptions::max_prior_distance_sigmas; max_sigmas <= 0: never).
bool beyondPriorDistance(const Eigen::Vector3d& centre, const CameraPrior& prior, double max_sigmas);

// The pin-hole camera the prior describes, optionally perturbed (yaw about world z, pitch about the camera's x
// axis, field of view scaled).
CameraModel cameraFromPrior(const CameraPrior& prior, int image_width, int image_height, double yaw_deg = 0.0,
                            double pitch_deg = 0.0, double fov_scale = 1.0);

struct LineMatcherOptions
{
  LineMatcherOptions();

  double max_angle_deg = 5.0;  // image line vs projected 3D line, once the search has run
  double initial_max_distance_px = 40.0;
  double known_camera_max_distance_px = 8.0;  // the first matching threshold from a known camera
  double min_distance_px = 4.0;               // thresholds never tighten below this
  double distance_factor = 4.0;               // re-matching threshold: this times the calibration's RMS error
  double distance_shrink = 0.5;  // ... reached by shrinking the previous threshold by at most this factor per iteration
  double min_overlap = 0.3;      // fraction of the image line's length the projected 3D line must cover
  double min_image_length_px = 30.0;  // shorter image lines are not matched
  int world_points_per_line = 6;      // samples along the visible part of a matched 3D line
  // Unmatched image lines of 3 or more points whose chord is at least this long join the final calibration as plumb
  // lines (CorrespondenceSet::straight_lines): they constrain the distortion. 0: none.
  double min_straight_line_px = 100.0;
  // Unmatched image lines whose chord is at least this long and that pass through the vanishing point of a known
  // direction under the matched camera (within RefinementOptions::max_direction_line_px) join it instead as images
  // of edges of that direction (CorrespondenceSet::direction_lines): they constrain the rotation and the intrinsics,
  // not the position. Known: the map's vertical and, with horizontal_direction_lines, the building's main horizontal
  // directions along which at least min_direction_support matched map lines run. 0: none.
  double min_direction_line_px = 60.0;
  bool horizontal_direction_lines = true;
  size_t min_direction_support = 3;
  // Ambiguity: an image line whose second-best 3D line is not worse by max(50 %, min_separation_px) is not matched,
  // unless both are within near_duplicate_px and lie within max(near_duplicate_m, 3 times their combined sigma) of
  // each other in 3D (the map holding one edge twice). Distinct edges that project onto one image line (a post's two
  // edges seen edge-on, 0.2 px apart at a view's border) leave it ambiguous: either match would bias the distortion.
  double min_separation_px = 1.0;
  double near_duplicate_px = 1.5;
  double near_duplicate_m = 0.02;
  int max_iterations = 10;
  int search_steps = 9;  // per dimension of the prior search (odd: includes the prior itself)
  // The search scores a camera by each image line's distance to its nearest compatible projected 3D line, capped
  // (8 % of the image diagonal on the grid); each round of the pattern search multiplies the cap by
  // search_cap_shrink, down to search_min_cap_px, so that the last rounds count precisely explained lines.
  double search_min_cap_px = 4.0;
  double search_cap_shrink = 0.5;
  int search_starts = 4;  // distinct search results each refined; the one explaining most image lines wins
  // The prior itself joins the starts as it is, without the pattern search (which moves a start by half the prior's
  // sigmas and can leave a prior that was close but stated with wide sigmas).
  bool prior_start = true;
  // Hypotheses from line correspondences (src/core/matching/hypotheses.cpp, docs/survey_calibration.md): cameras
  // anywhere in the prior's 3-sigma cone, their rotation and focal length from image lines taken as vertical or as
  // the map's dominant directions (hypothesis_iterations samples), their centre from image/map line pairs, scored
  // like the grid; the best hypothesis_starts distinct ones join the starts (0: none). Each rotation keeps its
  // hypothesis_centres best centres (a corridor's wrong centres can line up more pairs than the true one).
  int hypothesis_starts = 4;
  int hypothesis_centres = 3;
  int hypothesis_iterations = 4000;
  // Barrel distortions the hypotheses also try (px at the image corner, negative: inwards; 0 first: the lines as
  // they are): taken as straight, a wide camera's bent lines put the vanishing points and planes off. The best
  // hypothesis_distortion_starts distinct distorted ones join the straight lines' hypothesis_starts.
  std::vector<double> hypothesis_corner_px = {0.0, -20.0, -40.0, -60.0};
  int hypothesis_distortion_starts = 2;
  // The explanation score that picks among results: per image line its squared mean distance to the nearest
  // compatible projected 3D line, capped at this (px), summed.
  double explanation_cap_px = 1.0;
  // Local moves around the chosen result, alternated while they improve its explanation score (by more than
  // min_score_gain), at most max_local_rounds times:
  // - basin hopping (with the prior search only): 8 cameras moved by hop_position_m (along the axis with the focal
  //   length compensated, and sideways) or with the focal length scaled by 1 +- hop_focal_relative, each matched
  //   again from a first threshold of hop_max_distance_px;
  // - influence check: the influence_candidates most influential matches (Cook's distance at least min_influence)
  //   each banned in turn and the matching redone.
  int max_local_rounds = 6;
  // The local moves run from this many of the best refined starts (each to its own local optimum); the result
  // explaining the image best wins. 1: from the best start only. Starts that refined to the same camera as a better
  // one (centres within same_camera_m, rotations within same_camera_deg, focal lengths within same_camera_relative)
  // are skipped: the local moves from them would repeat its own; the next distinct starts fill up to this number.
  int local_search_starts = 3;
  double same_camera_m = 0.005;
  double same_camera_deg = 0.05;
  double same_camera_relative = 0.002;
  bool basin_hopping = true;
  double hop_position_m = 0.15;
  double hop_focal_relative = 0.04;
  double hop_max_distance_px = 20.0;
  std::vector<double> hop_scales = {1.0, 2.0};  // the moves above at each of these scales
  int abandon_after = 3;  // a hop still explaining the image worse than the current result after this many rounds
                          // of matching is abandoned
  int influence_candidates = 3;
  double min_influence = 0.5;
  // Optional: receives a line per step of the search (starts, matching rounds, local moves), for diagnosis.
  std::function<void(const std::string&)> trace;
  double min_score_gain = 0.05;  // a result replaces the current one when its score is lower by more than this
  // > 0 (matchAndCalibrate only): a result whose centre is farther than this many position sigmas from the prior
  // ranks behind every nearer one, however well it explains the image. The final check refuses such a result
  // (FixedCameraOptions::max_prior_distance_sigmas sets both), so choosing it would waste the nearer starts: in a
  // corridor a camera metres back with a longer focal length can explain the far lines better than the true one
  // explains them before its matches are complete.
  double max_prior_distance_sigmas = 0.0;
  // The survey's calibration: as calibrateCamera's defaults, with square pixels (one focal length, fx = fy:
  // refinement.single_focal), and a weak prior of a principal point near the image centre (3 % of the width), which
  // only matters for weakly constrained cameras. Square pixels: digital cameras have them (their sensors' pixels are
  // square and their streams not resampled), and a second focal length is one more direction a partial view leaves
  // open: over 57 accepted survey calibrations (sets AD-AG) fx - fy came out up to 0.55 % apart (90th percentile 0.19
  // %) under the 0.5 % square-pixel prior used before, and fx's error was up to 0.51 % where fy's was 0.04 %.
  // A camera whose stream is resampled to non-square pixels (an analogue camera's 720x576 PAL or 720x480 NTSC
  // digitiser) needs refinement.single_focal false (parameter square_pixels): fx and fy apart, without a prior.
  // (FixedCamera fits a correspondence file so whatever the parameter.)
  CalibrationOptions calibration;
};

struct LineMatch
{
  size_t image_line;
  size_t map_line;
  double distance_px;  // mean distance of the image line's points to the projected 3D line
};

struct LineMatchResult
{
  std::vector<LineMatch> matches;            // the final matches (inliers of the final calibration)
  std::vector<LineMatch> candidate_matches;  // all matches of the last round (the lines of correspondences)
  CorrespondenceSet correspondences;         // built from them
  CameraCalibration calibration;
  CameraModel search_camera;  // the camera the prior search found
  int iterations = 0;
  bool converged = false;  // the match set stopped changing
};

// Which refined starts the local moves run from: indices into `cameras` (the refined starts, best explanation first) of
// the first options.local_search_starts (at least 1) that are not the same camera (the options' same_camera_*
// tolerances) as one chosen before them.
std::vector<size_t> distinctStarts(const std::vector<CameraModel>& cameras, const LineMatcherOptions& options);

// map_lines: 3D segments in the world; image_lines: distorted-pixel polylines of the fixed camera;
// map_line_sigmas_m: optional, per map line how far off it may be (LineCorrespondence::world_sigma_m).
// image_line_world_sigmas_m: optional, per image line how far the 3D line it shows may be from the map line it
// matches (a thin line's centre from the joint's edges: FixedCameraOptions::thin_line_sigma_m); added in quadrature.
// final_map_line_sigmas_m: optional (used with one entry per map line), in place of map_line_sigmas_m in the chosen
// result's final calibration and its uncertainty only (lines known less well than the search should weigh them: map
// lines that are one flank of a joint the camera does not resolve, map/joint_lines.h).
Expected<LineMatchResult> matchAndCalibrate(const std::vector<Segment3d>& map_lines,
                                            const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                            const CameraPrior& prior, int image_width, int image_height,
                                            const LineMatcherOptions& options = {},
                                            const std::vector<double>& map_line_sigmas_m = {},
                                            const std::vector<double>& image_line_world_sigmas_m = {},
                                            const std::vector<double>& final_map_line_sigmas_m = {});

// Steps 2 and 3 from a camera known to be close (an earlier calibration: the paper's loop after re-extracting the
// image lines with its distortion), without the prior search.
Expected<LineMatchResult> matchAndCalibrateFrom(const std::vector<Segment3d>& map_lines,
                                                const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                                const CameraModel& start, int image_width, int image_height,
                                                const LineMatcherOptions& options = {},
                                                const std::vector<double>& map_line_sigmas_m = {},
                                                const std::vector<double>& image_line_world_sigmas_m = {},
                                                const std::vector<double>& final_map_line_sigmas_m = {});

// How well a camera explains the image lines, the score the matcher picks among its starts and local moves by: per
// image line the squared mean distance to the nearest compatible projected map line, capped at
// options.explanation_cap_px^2, summed. Lower is better; scores of one set of image lines compare.
double explanationScore(const std::vector<Segment3d>& map_lines,
                        const std::vector<std::vector<Eigen::Vector2d>>& image_lines, const CameraModel& camera,
                        int image_width, int image_height, const LineMatcherOptions& options = {});

// Per image line (of image_line_count), whether one of the matches has it.
std::vector<bool> matchedImageLines(const std::vector<LineMatch>& matches, size_t image_line_count);

// Step 2 alone: matches under a given camera.
std::vector<LineMatch> matchLines(const std::vector<Segment3d>& map_lines,
                                  const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                  const CameraModel& camera, int image_width, int image_height, double max_angle_deg,
                                  double max_distance_px, const LineMatcherOptions& options);

// The part of a 3D segment the camera sees (in front, inside the image), as parameters [t0, t1] along a -> b;
// nullopt when no part is visible.
std::optional<std::pair<double, double>> visibleInterval(const CameraModel& camera, const Segment3d& segment,
                                                         int image_width, int image_height);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MATCHING_LINE_MATCHER_H
