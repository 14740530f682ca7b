// calibrate_survey: the calibration node's pipeline run offline on a recorded survey bag, without a ROS master:
// the Xtion's frames (with the poses of /tf and /tf_static) build the line map, the fixed cameras' images their
// medians, and every configured camera is calibrated and written like the node writes it.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <optional>
#include <iostream>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "command_line.h"
#include "insitu_calibration/refine/refinement.h"
#include "insitu_calibration/lines/depth_registration.h"
#include "insitu_calibration/lines/line_evaluation.h"
#include "insitu_calibration/matching/direction_lines.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/ros/survey_bag_reader.h"
#include "insitu_calibration/simulation/edge_sightings.h"
#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "insitu_calibration/survey/camera_config.h"
#include "insitu_calibration/survey/calibration_report.h"
#include "insitu_calibration/survey/overlay.h"
#include "insitu_calibration/io/calibration_store.h"
#include "insitu_calibration/survey/survey.h"
#include "insitu_calibration/survey/survey_guidance.h"
#include "insitu_calibration/survey/uncertainty_budget.h"
#include "insitu_calibration/survey/survey_hint_file.h"
#include "insitu_calibration/survey/survey_parameters.h"
#include "insitu_calibration/geometry/optical_frame.h"

namespace ic = insitu_calibration;

namespace
{
const char* kUsage = R"(Usage: calibrate_survey BAG [BAG ...] --cameras CAMERAS.yaml --out-dir DIR [options]

Runs the calibration node's pipeline offline on a survey bag (no ROS master needed): keyframes of the Xtion
(/camera/rgb/image_raw, /camera/depth_registered/image_raw, /camera/rgb/camera_info, posed with /tf and /tf_static
in the world frame) build the 3D line map; each configured fixed camera's images (its image_topic) build its temporal
median; then every camera is calibrated (prior matching or correspondence file) and DIR/<camera>.yaml and
DIR/<camera>_overlay.png are written, as the node writes them, with the calibration report DIR/<camera>_report.html
and its PNG figures (README, "The calibration report"; also for a result the checks refused, saying why). A refused
camera also gets DIR/<camera>_survey_hint.png (the parts of its view without map lines) and
DIR/<camera>_survey_hint.yaml (the same for programs: per region a standpoint and look direction in the map frame,
the floor polygon; generate_world --visit-hints reads it), and its message says where to drive the robot (README
"When a camera is refused"). An accepted camera's line gives its 1 sigma from the matched lines (what the checks
use), the next the sigma saved in the map frame and its parts (README, "Offline: calibrate_survey").
Several bags are recordings of one survey (e.g. the first drive, then the hints' visits with the Xtion re-tilted as
they advise), read in order into one map: neither odometry nor the localiser's chain ties one recording to the next.

Options:
  --cameras FILE        fixed-camera configuration (config/cameras.yaml format)
  --params FILE         calibration_node's parameters (README, "On the robot": max_rms_px, ransac_threshold_px,
                        localization_sigma_m, keyframe/min_translation, ...) as YAML, e.g. from
                        `rosparam dump FILE /calibration_node` (default: the --cameras file, which the node loads as
                        its parameters too); the flags below override them
  --out-dir DIR         where to write the calibrations
  --world-frame NAME    default map
  --min-support N       map lines seen fewer times are not used (default 2)
  --max-spread M        map lines whose observations spread more (RMS across the line, m) are not used (default 0.01)
  --localization-sigma M,DEG[,TAU]
                        the localiser's error behind the bag's tf (per keyframe x, y sigma in m, yaw sigma in
                        degrees, correlation time in s): the line map is adjusted jointly with the keyframe poses
                        (their priors to tf a Gauss-Markov chain with that correlation time) and the calibration's
                        sigma includes the map's placement (default 0.02,0.5,5; 0,0: tf is exact, no adjustment)
  --odom-frame NAME     the odometry frame (default odom): consecutive keyframes are tied by their motion in it
  --no-odometry         the map adjustment without odometry
  --odometry-sigma M,PER_M,DEG,PER_DEG
                        odometry's error between consecutive keyframes: M + PER_M times the distance, DEG + PER_DEG
                        times the turn (default 0.0005,0.01,0.02,0.01: good wheel odometry)
  --depth-registration X,Y
                        the Xtion's depth image misregistered with its RGB image: the depth pixel (u, v) measures
                        the RGB pixel (u + X, v + Y) (parameters depth_registration/x_px, y_px): the edges' depth is
                        read where it belongs (a surface seen at a grazing angle otherwise puts the map lines
                        millimetres to centimetres off, docs/measurements.md); 0,0 with sigma 0.5 px: the behaviour
                        before auto became the default
  --depth-registration auto | estimate
                        estimate X,Y from the survey itself (a first pass over the bag's RGB-D frames: the creases
                        where two surfaces meet, seen in depth and in RGB; lines/depth_registration.h) and print it
                        with its sigma; auto then uses it and its sigma (refused estimate: 0,0 with the reason),
                        estimate exits. Default: auto, unless the parameters (--params or the --cameras file) give
                        depth_registration/x_px or y_px, which are then used as they are
  --depth-registration-sigma PX
                        the registration's uncertainty, px per axis (default 0.5, or the estimate's larger sigma
                        with auto; parameter depth_registration/sigma_px): times the depth's slope at an edge, the
                        error every sighting of that edge shares: the map adjustment weighs such a line's depth
                        less, so the keyframe poses do not bend to it (and with the parameter
                        depth_registration/in_map_line_sigma true the map line's sigma keeps it); 0: exact
  --floor-lines 0|1     RGB lines beyond the depth range placed on the floor plane and confirmed from several
                        keyframes become map lines (default 0: off)
  --floor-height M      the floor plane's z in the world frame (default 0)
  --floor-max-range M   floor lines farther from the camera are not used (default 12)
  --floor-extended 0|1  with --floor-lines 1: floor lines seen only along the route (their slope test
                        unresolved) are confirmed by depth that put them on the floor in 2 or more keyframes or as
                        the continuation of a confirmed floor line, and depth lines on the floor too uncertain for
                        the map become floor candidates (default 0: off)
  --ceiling-lines 0|1   RGB lines on the ceiling (the horizontal plane above the Xtion that its depth lines
                        measured) whose own depth is too poor for the map or missing, placed on it by ray-plane
                        intersection and confirmed from several keyframes, become map lines (default 0: off)
  --extended-retry 0|1  a camera the map refuses is tried once more against the map with its extensions (fused
                        uncertain depth lines, --max-fusion-sigma 0.012, and ceiling lines); a camera the map
                        calibrates keeps that result (params extended_retry; default 1: on)
  --max-fusion-sigma M  observations too uncertain for the map alone (sigma above 3 mm) up to M m are fused into
                        map lines used when many keyframes agree (params map/max_fusion_sigma; default 0: off;
                        0.012 measured: docs/measurements.md, "Fusion measured again")
  --min-fusion-keyframes N
                        distinct keyframes a fused map line needs (params map/min_fusion_keyframes, default 4)
  --fusion-floor M      added in quadrature to a fused map line's predicted error: what averaging cannot remove
                        (params map/fusion_floor, default 0.005)
  --depth-step-sigmas K a depth step between an edge's two sides too small for one frame (a panel a few mm proud
                        of its wall) is pooled over a map line's observations; beyond K standard errors (and 1 mm,
                        params map/depth_step_min) its observations take the nearer side's depth (params
                        map/depth_step_sigmas, default 0: off; 5 measured: docs/measurements.md, "Depth steps
                        pooled over the keyframes")
  --depth-slant-allowance 0|1
                        the depth sampler's jump (what counts as a farther surface beside an edge) widened by how fast
                        depth grows across the edge on a slanted surface (params depth/slant_allowance, default 1;
                        0: the jump from the nearest reading alone, as before 2026-12-04)
  --triangulated-lines 0|1
                        RGB lines beyond the depth range (4 m) triangulated from five or more keyframes become map lines
                        (default 0: off)
  --triangulated-repetition-px PX
                        with --triangulated-lines 1: a line with another parallel segment beside it within PX px in
                        half of its keyframes (brick courses, tiles) is left out (default 10; 0: kept)
  --occlusion-test 0|1  the final check leaves out map lines that surfaces the survey's depth measured hide from
                        the camera (default 1)
  --plain-floor-samples 0|1
                        the final check leaves floor samples out one by one where the floor looks plain there
                        instead of whole plain floor lines (params plain_floor_samples; default 1)
  --square-pixels 0|1   the fixed cameras' pixels are square: one focal length, fx = fy (params square_pixels;
                        default 1; 0 for a stream resampled to non-square pixels, such as an analogue camera's
                        720x576 digitiser: fx and fy estimated apart)
  --plain-ceiling-samples 0|1
                        the final check tests lines on the ceiling the survey's depth lines measured as floor lines
                        (their samples left out where the image looks plain; params plain_ceiling_samples;
                        default 1)
  --texture-min-neighbours N
                        the final check leaves samples of texture lines (joints of bricks, tiles, panels: N or more
                        parallel map lines side by side) out where the image shows no edge on or beside them
                        (params texture_min_neighbours; default 0: off; 4 turns it on)
  --overlay-min-gradient G
                        the final check's edge: a gradient of at least G grey levels per px across a projected map
                        line (params overlay_min_gradient; default 4)
  --faint-edge-gradient G
                        the final check counts a line's plain samples (no edge on or beside them) as on an edge
                        when, averaged along the line, the step across it reaches G grey levels per px, 4 standard
                        errors and 3 times the step 4 px beside it: a faint crease (params faint_edge_gradient;
                        default 1; 0: off)
  --chance-mapped-radius R
                        the final check measures its chance level beside a line at places at least R px from every
                        other map line's projection (an edge there is explained by the map, not met by chance) and
                        leaves out samples with no such place (params chance_mapped_radius; default 3; 0: 4 px beside
                        every sample)
  --chance-both-sides 0|1
                        with a chance-mapped radius: a sample counts only where both its sides have such a place (1),
                        or where either has (0) (params chance_both_sides; default 1)
  --occlusion-other-surface-margin M
                        the occlusion test hides a map line's point behind a surface other than the line's own
                        down to M m before it (params occlusion_other_surface_margin; default 0.1; 0: only beyond
                        0.3 m + 8 % of the range, as before 2026-12-07)
  --occluders-follow-adjustment 0|1
                        those surfaces are inserted again under the map adjustment's corrected keyframe poses
                        (default 0: at tf's poses)
  --camera NAME         calibrate only this camera
  --search-starts N     distinct results of the prior search refined per camera (default 4)
  --local-search-starts N
                        the local moves (basin hopping, influence check) run from this many of the best refined
                        starts, the best result wins (default 3; 1: from the best start only)
  --hypothesis-starts N extra starts from line-correspondence hypotheses in the prior's 3-sigma cone (default 4)
  --hypothesis-centres N
                        centres kept per rotation hypothesis (params hypothesis_centres; default 3)
  --prior-start 0|1     the prior itself is one of the starts, as it is (params prior_start; default 1)
  --ambiguity-neighbourhood SHARE
                        the ambiguity test also redoes the matching from the accepted camera moved by SHARE of the
                        scene's depth towards the faces and corners of a cube around it (params
                        ambiguity/neighbourhood_share; default 0.05; 0: only the map's repetitions are tried)
  --ambiguity-better-score MARGIN
                        a start of the ambiguity test that ends at the same camera and explains the image better by
                        at least MARGIN (capped lines, with as many matched lines) replaces the result when it
                        passes every check (params ambiguity/better_score_margin; default 0.5; 0: never)
  --truth-dir DIR[,DIR ...]
                        the simulator's truth folder (<bag>_truth); with several bags, one per bag in their order,
                        or one of them (the building and cameras are the same; then without the localiser's lines
                        "truth-limit" and "truth-keyframes", which need each recording's own errors): also report,
                        per camera, how many matches pair the wrong edges and how far the matched map lines are
                        from the true edges, the localiser's limit (its error averaged over the keyframes, at the
                        camera: "truth-limit" lines; over the keyframes that observed the camera's matched lines,
                        as tf gave them and adjusted, beside the placement sigma predicted for them:
                        "truth-local-limit" lines) and the cameras' poses relative to each other against the
                        truth ("truth-relative" lines), the map's coverage of each camera's image lines
                        ("truth-coverage" lines) and how much of an accepted camera's error its lines' true offsets
                        explain, all, wrong matches and right ones (linearised through the refinement: the
                        camera's change when the lines move onto their true edges, so an explained error has the
                        opposite sign; focal, lambda, rotation, position: "truth-line-shift" lines), how many of
                        its final calibration's direction lines show an edge of their given direction, of another
                        or none, and how far off ("truth-direction-lines" lines), and where
                        each of the ambiguity test's alternatives ended ("truth-alternative" lines; the search's
                        result, when a start explaining the image better replaced it: "truth-replaced")
  --coverage-diagnosis WORLD
                        with --truth-dir: per image line the map lacks, why (the simulator's WORLD file rendered
                        at each keyframe: never in the Xtion's view (-mount: at a height the mount has nowhere in
                        view within the depth range), in view without depth, with depth but no 3D
                        line, 3D lines too uncertain for the map, in the map but not used or off): "truth-missing"
                        lines, the share of the image lines' length per cause; and the final check measured on the
                        TRUE camera, with why its samples find no image edge (WORLD rendered from it: hidden from it
                        by a surface the occlusion test missed, a true edge in view that shows no edge (the map
                        point within 1 px of it, or farther), no true edge): "truth-check" lines; the check's
                        numbers and verdict for the result and each of the ambiguity test's alternatives, with
                        their errors, and the verdict with the chance level measured 4 px beside every sample
                        (chance_mapped_radius 0) and with the other chance_both_sides rule: "truth-agreement" lines
  --prior-from-truth P,D,F[,SEED]
                        with --truth-dir: replace every camera's prior by its true camera moved P m in a random
                        direction, its viewing direction turned D degrees (about a random axis across it; the
                        roll stays true) and its field of view scaled by 1 +- F
                        (sign random); the sigmas stay as configured. Tests the matching from other priors.
  --prior-sigmas P,D,F  with --prior-from-truth: the priors' position, direction and field-of-view sigmas
  --principal-point-from-truth SIGMA_PX[,SEED]
                        with --truth-dir: every prior knows its camera's principal point (prior.principal_point),
                        the true one moved by a normal error of SIGMA_PX px per axis, with that sigma: how much a
                        principal point known from a lab calibration helps (narrow views)
  --oracle              with --truth-dir: instead of the pipeline, calibrate on the matches the TRUE camera makes
                        (with the other long image lines as direction and plumb lines, as the final calibration
                        does): the accuracy the map and image lines allow when matching is perfect; also with the
                        map lines replaced by their true edges (true 3D), the matched image lines by the true
                        edges' images (true 2D) and both (nearly exact: the direction and plumb lines stay real)
  --oracle-details      with --oracle: per image line its true edge and map lines, per match the map line's
                        support, spread and error, the image points' distances to the true edge, and per
                        direction line its true edge, its angle to the given direction and its end points'
                        distances to that edge
  --trace               print the matcher's steps (starts, matching rounds, local moves) to stderr
  --no-refine           the paper's linear DLT after matching (no Ceres refinement)
  --no-ransac           no RANSAC over the matched lines
  --no-report           do not write the calibration reports
  --quiet               print only errors and the result table

Exit status: 0 when every camera calibrated, 1 when one failed, 2 on bad arguments or an unreadable bag.
)";

// The camera's error the matched lines' true 3D offsets explain (linearised, predictCameraShift): each inlier line
// moved from its map line onto the true edge its image line shows (for a wrong match, the other edge), all of them,
// the wrong matches only and the others ("truth-line-shift" lines: the correction, the error's opposite sign).
void reportLineShiftsAgainstTruth(const ic::CameraModel& truth, const std::vector<ic::Segment3d>& segments,
                                  const std::vector<ic::TrueEdgeImage>& images, const ic::FixedCameraResult& result,
                                  const ic::RefinementOptions& options, const std::string& name)
{
  ic::CorrespondenceSet inliers = result.correspondences;
  inliers.lines.clear();
  std::vector<Eigen::Vector3d> moves;
  std::vector<bool> wrong;
  for (size_t k = 0; k < result.correspondences.lines.size(); ++k)
  {
    if (k >= result.calibration.inlier_lines.size() || !result.calibration.inlier_lines[k])
      continue;
    const ic::LineCorrespondence& line = result.correspondences.lines[k];
    inliers.lines.push_back(line);
    const ic::ImageLineError shown = ic::measureImageLine(line.image, truth.distortion(), images, 3.0, 1.0, 0.6);
    const ic::Line3dError mapped = ic::measureLine3d(line.world.front(), line.world.back(), segments, 0.1, 5.0);
    Eigen::Vector3d move = Eigen::Vector3d::Zero();
    if (shown.edge >= 0)
    {
      const ic::Segment3d& t = segments[shown.edge];
      const Eigen::Vector3d u = (t.b - t.a).normalized(), mid = 0.5 * (line.world.front() + line.world.back());
      const Eigen::Vector3d off = (mid - t.a) - (mid - t.a).dot(u) * u;
      move = -off;
    }
    moves.push_back(move);
    wrong.push_back(shown.edge >= 0 && mapped.edge != shown.edge && move.norm() > 0.03);
  }
  const ic::CameraErrors actual = ic::compareCameras(truth, result.calibration.camera);
  const double f = truth.intrinsics().fx;
  const double lambda = truth.distortion().lambda;
  auto lambdaPercent = [&](double change) { return lambda != 0.0 ? 100.0 * change / std::abs(lambda) : 0.0; };
  std::printf("truth-line-shift %s actual: focal %+.3f %%, lambda %+.2f %%, rotation %.3f deg, position %.1f mm\n",
              name.c_str(), 100.0 * actual.focal_relative,
              lambdaPercent(result.calibration.camera.distortion().lambda - lambda), actual.rotation_rad * 180.0 / M_PI,
              1000.0 * actual.center_m);
  for (int group = 0; group < 3; ++group)
  {
    std::vector<Eigen::Vector3d> some = moves;
    for (size_t k = 0; k < some.size(); ++k)
      if ((group == 1 && !wrong[k]) || (group == 2 && wrong[k]))
        some[k].setZero();
    const auto shift = ic::predictCameraShift(inliers, result.calibration.camera, options, some);
    if (!shift)
      return;
    std::printf("truth-line-shift %s %s: focal %+.3f %%, lambda %+.2f %%, rotation %.3f deg, position %.1f mm\n",
                name.c_str(),
                group == 0   ? "all lines"
                : group == 1 ? "wrong matches"
                             : "right matches",
                100.0 * shift->fx_px / f, lambdaPercent(shift->lambda), shift->rotation_rad.norm() * 180.0 / M_PI,
                1000.0 * shift->center_m.norm());
  }
}

// The true edge a direction line shows (ImageLineError::edge, -1: none) and the angle between that edge and the
// direction the line was given (deg; -1 without an edge).
struct DirectionLineTruth
{
  ic::ImageLineError shown;
  double angle_deg = -1.0;
};

DirectionLineTruth directionLineTruth(const ic::DirectionLine& line, const ic::CameraModel& truth,
                                      const std::vector<ic::Segment3d>& segments,
                                      const std::vector<ic::TrueEdgeImage>& images)
{
  DirectionLineTruth out;
  out.shown = ic::measureImageLine(line.image, truth.distortion(), images, 3.0, 1.0, 0.6);
  if (out.shown.edge >= 0)
  {
    const Eigen::Vector3d e = (segments[out.shown.edge].b - segments[out.shown.edge].a).normalized();
    out.angle_deg = std::acos(std::min(1.0, std::abs(e.dot(line.direction)))) * 180.0 / M_PI;
  }
  return out;
}

// The final calibration's direction lines against the truth ("truth-direction-lines"): how many show an edge of the
// direction they were given (within 1 deg), of another direction, or no edge, and the image lines' distance to their
// true edges' images (the vanishing point is what they measure: a direction taken wrongly turns the camera).
void reportDirectionLinesAgainstTruth(const ic::CameraModel& truth, const std::vector<ic::Segment3d>& segments,
                                      const std::vector<ic::TrueEdgeImage>& images, const ic::FixedCameraResult& result,
                                      const std::string& name)
{
  const auto& lines = result.correspondences.direction_lines;
  if (lines.empty())
    return;
  size_t right = 0, other = 0, none = 0;
  std::vector<double> rms;
  for (const auto& line : lines)
  {
    const DirectionLineTruth shown = directionLineTruth(line, truth, segments, images);
    if (shown.shown.edge < 0)
    {
      ++none;
      continue;
    }
    (shown.angle_deg <= 1.0 ? right : other) += 1;
    rms.push_back(shown.shown.rms_px);
  }
  std::sort(rms.begin(), rms.end());
  std::printf(
      "truth-direction-lines %s: %zu, on an edge of their direction %zu, of another %zu, on none %zu; "
      "RMS to the edge median %.2f px, max %.2f px\n",
      name.c_str(), lines.size(), right, other, none, rms.empty() ? 0.0 : rms[rms.size() / 2],
      rms.empty() ? 0.0 : rms.back());
}

// The ambiguity test's alternatives against the truth: did one of its starts reach the true camera, and how did
// it compare?
void reportAlternativesAgainstTruth(const ic::CameraModel& truth, const ic::ViewAmbiguity& ambiguity)
{
  for (const ic::AlternativeCamera& alt : ambiguity.alternatives)
  {
    const ic::CameraErrors e = ic::compareCameras(truth, alt.calibration.camera);
    if (alt.replaced_result)
    {
      std::printf(
          "  truth-replaced: the search's result: focal %+.3f %%, rotation %.3f deg, position %.1f mm; score "
          "%.2f (the result %.2f), %zu lines (the result %zu)\n",
          100.0 * e.focal_relative, e.rotation_rad * 180.0 / M_PI, 1000.0 * e.center_m, alt.score,
          ambiguity.accepted_score, alt.matched_lines, ambiguity.accepted_matched);
      continue;
    }
    std::printf(
        "  truth-alternative: start %s %.2f m%s: focal %+.3f %%, rotation %.3f deg, position %.1f mm; "
        "score %.2f (the result %.2f), %zu lines (the result %zu)%s%s\n",
        alt.from_neighbourhood ? "neighbourhood" : "repetition", alt.shift.norm(),
        alt.focal_compensated ? " (focal compensated)" : "", 100.0 * e.focal_relative, e.rotation_rad * 180.0 / M_PI,
        1000.0 * e.center_m, alt.score, ambiguity.accepted_score, alt.matched_lines, ambiguity.accepted_matched,
        alt.clearly_different ? "" : "; not clearly different",
        alt.dismissed.empty() ? "" : ("; " + alt.dismissed).c_str());
  }
}

// The building's and cameras' truth: the first of --truth-dir's folders (one, or one per bag: every recording's
// building and cameras are the same).
std::string truthDir(const ic::CommandLine& cli)
{
  const auto dirs = cli.items("truth-dir");
  return dirs.empty() ? std::string() : dirs.front();
}

// Each keyframe's localiser error from its own recording's localization.yaml (the folders in the bags' order);
// nothing when the folders do not match the recordings one to one or a file is missing.
std::optional<std::vector<ic::simulation::Pose2d>> keyframeLocalizationErrors(const std::vector<std::string>& dirs,
                                                                              const ic::Survey& survey)
{
  std::vector<std::vector<ic::simulation::LocalizationSample>> recordings;
  for (const auto& dir : dirs)
  {
    auto loaded = ic::simulation::loadLocalizationErrors(dir + "/localization.yaml");
    if (!loaded || loaded->empty())
      return std::nullopt;
    recordings.push_back(std::move(*loaded));
  }
  std::vector<ic::simulation::Pose2d> errors;
  size_t recording = 0;
  for (const auto& kf : survey.keyframes())
  {
    if (kf.starts_recording && !errors.empty())
      ++recording;
    if (recording >= recordings.size())
      return std::nullopt;
    errors.push_back(ic::simulation::nearestLocalizationSample(recordings[recording], kf.stamp).error);
  }
  if (recording + 1 != recordings.size())
    return std::nullopt;
  return errors;
}

// The localiser's true mean error over the keyframes that observed the camera's matched lines, at the camera, as tf
// gave the poses and after the adjustment's corrections, beside the placement sigma the calibration predicts for
// them ("truth-local-limit" lines): how far the map is off where the camera's lines are.
void reportLocalPlacementAgainstTruth(const std::vector<std::string>& truth_dirs, const ic::Survey& survey,
                                      const std::string& name, const ic::FixedCameraResult& result)
{
  const auto errors = keyframeLocalizationErrors(truth_dirs, survey);
  const auto truth = ic::loadCalibrationFile(truth_dirs.front() + "/" + name + ".yaml");
  if (!errors || !truth)
    return;
  const std::vector<ic::MapLine> used = survey.usedMapLines();
  const auto lines = ic::Survey::matchedMapLines(result, used);
  const std::vector<size_t> observing = ic::keyframesObserving(survey.keyframes(), lines);
  const auto corrections = survey.poseCorrections();
  std::vector<ic::simulation::Pose2d> before, after;
  std::vector<Eigen::Vector3d> pivots;
  for (size_t k : observing)
  {
    const ic::simulation::Pose2d& e = (*errors)[k];
    before.push_back(e);
    after.push_back({e.x + corrections[k].x, e.y + corrections[k].y, e.yaw + corrections[k].yaw});
    pivots.push_back(survey.keyframes()[k].T_map_camera.translation());
  }
  const Eigen::Vector3d centre = truth->camera.pose().center();
  const auto tf = ic::simulation::placementLimit(before, pivots, centre);
  const auto adjusted = ic::simulation::placementLimit(after, pivots, centre);
  const ic::MapPlacementUncertainty local = survey.mapPlacementOf(lines), whole = survey.mapPlacement();
  std::printf(
      "truth-local-limit %s over %zu keyframes: tf %.2f mm %.4f deg, adjusted %.2f mm %.4f deg; predicted 1 "
      "sigma %.2f mm %.4f deg (the survey's %.2f mm %.4f deg)\n",
      name.c_str(), observing.size(), 1000.0 * tf.position_m, tf.rotation_rad * 180.0 / M_PI,
      1000.0 * adjusted.position_m, adjusted.rotation_rad * 180.0 / M_PI, 1000.0 * local.atPoint(centre),
      local.sigma_deg, 1000.0 * whole.atPoint(centre), whole.sigma_deg);
}

// Diagnostics against the simulator's truth: the true edge of each matched image line (under the true camera) and
// of each matched map line; a match is wrong when they differ.
void reportAgainstTruth(const std::string& truth_dir, const std::string& name, const ic::FixedCameraResult& result,
                        const ic::RefinementOptions& options)
{
  const auto truth = ic::loadCalibrationFile(truth_dir + "/" + name + ".yaml");
  const auto edges = ic::simulation::loadTrueEdges(truth_dir + "/edges.yaml");
  if (!truth || !edges)
  {
    std::printf("  truth: %s\n", (!truth ? truth.error() : edges.error()).describe().c_str());
    return;
  }
  std::vector<ic::Segment3d> segments;
  for (const auto& e : *edges)
    segments.push_back({e.start, e.end});
  const auto images = ic::projectEdges(truth->camera, segments);
  size_t wrong = 0, unknown_image = 0, unknown_map = 0;
  std::vector<double> map_errors_mm;
  for (size_t k = 0; k < result.matched_image_lines.size(); ++k)
  {
    const ic::ImageLineError image_error =
        ic::measureImageLine(result.matched_image_lines[k], truth->camera.distortion(), images, 3.0, 1.0, 0.6);
    const ic::Segment3d& m = result.matched_map_lines[k];
    const ic::Line3dError map_error = ic::measureLine3d(m.a, m.b, segments, 0.1, 5.0);
    if (map_error.edge < 0)
      ++unknown_map;
    else
      map_errors_mm.push_back(1000.0 * map_error.distance_m);
    if (image_error.edge < 0)
      ++unknown_image;
    else if (map_error.edge >= 0)
    {
      // Collinear true edges (one straight line split in two) are the same line for calibration.
      const ic::Segment3d& a = segments[image_error.edge];
      const ic::Segment3d& b = segments[map_error.edge];
      const Eigen::Vector3d d = (a.b - a.a).normalized();
      const bool collinear =
          std::abs(d.dot((b.b - b.a).normalized())) > 0.9999 && ((b.a - a.a) - d * d.dot(b.a - a.a)).norm() < 1e-3;
      if (image_error.edge != map_error.edge && !collinear)
      {
        ++wrong;
        std::printf(
            "  truth-wrong-match: image line on edge [%.2f %.2f %.2f] -> [%.2f %.2f %.2f], map line on edge "
            "[%.2f %.2f %.2f] -> [%.2f %.2f %.2f]\n",
            a.a.x(), a.a.y(), a.a.z(), a.b.x(), a.b.y(), a.b.z(), b.a.x(), b.a.y(), b.a.z(), b.b.x(), b.b.y(), b.b.z());
      }
    }
  }
  const ic::ReprojectionStats map_stats = ic::summarize(map_errors_mm);
  std::printf(
      "  truth: %zu matches, %zu pair different edges, %zu image lines and %zu map lines on no true edge; "
      "matched map lines off their edge by median %.2f mm, max %.2f mm\n",
      result.matched_image_lines.size(), wrong, unknown_image, unknown_map, map_stats.median_px, map_stats.max_px);
  reportLineShiftsAgainstTruth(truth->camera, segments, images, result, options, name);
  reportDirectionLinesAgainstTruth(truth->camera, segments, images, result, name);
  reportAlternativesAgainstTruth(truth->camera, result.ambiguity);
}

// Diagnostic: how far from the truth a result the checks refused was (was the refusal needed?).
void reportRefusedAgainstTruth(const std::string& truth_dir, const std::string& name,
                               const ic::FixedCameraResult& refused)
{
  const auto truth = ic::loadCalibrationFile(truth_dir + "/" + name + ".yaml");
  if (!truth)
    return;
  const ic::CameraErrors e = ic::compareCameras(truth->camera, refused.calibration.camera);
  std::printf("  truth of the refused result: focal %+.3f %%, rotation %.3f deg, position %.1f mm\n",
              100.0 * e.focal_relative, e.rotation_rad * 180.0 / M_PI, 1000.0 * e.center_m);
  reportAlternativesAgainstTruth(truth->camera, refused.ambiguity);
}

// The keyframes' pose errors (x, y, yaw) before and after the map adjustment: RMS and mean (the survey's
// placement error), from the localiser's error of the truth and the adjustment's corrections.
void reportKeyframesAgainstTruth(const std::vector<ic::simulation::Pose2d>& errors, const ic::Survey& survey)
{
  const auto corrections = survey.poseCorrections();
  Eigen::Vector3d sum_before = Eigen::Vector3d::Zero(), sum_after = sum_before, sq_before = sum_before,
                  sq_after = sum_before;
  size_t n = 0;
  for (size_t k = 0; k < survey.keyframes().size() && k < errors.size(); ++k)
  {
    const Eigen::Vector3d before(errors[k].x, errors[k].y, errors[k].yaw);
    const Eigen::Vector3d after = before + Eigen::Vector3d(corrections[k].x, corrections[k].y, corrections[k].yaw);
    sum_before += before;
    sum_after += after;
    sq_before += before.cwiseAbs2();
    sq_after += after.cwiseAbs2();
    ++n;
  }
  if (n == 0)
    return;
  auto print = [&](const char* what, const Eigen::Vector3d& sum, const Eigen::Vector3d& sq) {
    const Eigen::Vector3d mean = sum / n;
    const Eigen::Vector3d spread = (sq / n - mean.cwiseAbs2()).cwiseMax(0.0).cwiseSqrt();
    std::printf("truth-keyframes %s: mean x %+.1f y %+.1f mm yaw %+.3f deg; about it x %.1f y %.1f mm yaw %.3f deg\n",
                what, 1000.0 * mean.x(), 1000.0 * mean.y(), mean.z() * 180.0 / M_PI, 1000.0 * spread.x(),
                1000.0 * spread.y(), spread.z() * 180.0 / M_PI);
  };
  print("tf", sum_before, sq_before);
  print("adjusted", sum_after, sq_after);
}

// Medians of a group of RGB-D lines' offsets from their true edges (truth-observations, truth-maplines lines).
struct OffsetGroup
{
  std::vector<double> depth_mm, lateral_mm, sigma_mm, ratio, shared_mm;
};

void printOffsetGroups(const char* what, const std::map<std::string, OffsetGroup>& groups)
{
  auto median = [](std::vector<double> v) {
    if (v.empty())
      return std::nan("");
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  auto absolute = [](std::vector<double> v) {
    for (double& x : v)
      x = std::abs(x);
    return v;
  };
  for (const auto& [key, g] : groups)
  {
    size_t beyond = 0;
    for (double r : g.ratio)
      beyond += r > 3.0;
    std::printf(
        "%s %-22s n %5zu  depth median %+6.2f |%5.2f| mm  lateral %+5.2f |%5.2f| mm  sigma %5.2f mm  "
        "|off|/sigma median %5.2f, > 3: %4.1f %%  shared %5.2f mm\n",
        what, key.c_str(), g.depth_mm.size(), median(g.depth_mm), median(absolute(g.depth_mm)), median(g.lateral_mm),
        median(absolute(g.lateral_mm)), median(g.sigma_mm), median(g.ratio),
        g.ratio.empty() ? 0.0 : 100.0 * beyond / g.ratio.size(), median(g.shared_mm));
  }
}

// Every keyframe's RGB-D line (at tf's pose) against the true edges, in the sensor's terms (depth along the ray,
// lateral across it), per edge kind, range and angle to the ray: where the map lines' offset comes from.
void reportObservationsAgainstTruth(const std::vector<ic::simulation::TrueEdge>& edges,
                                    const std::vector<ic::Segment3d>& segments, const ic::Survey& survey)
{
  std::map<std::string, OffsetGroup> groups;
  for (const auto& kf : survey.keyframes())
    for (const auto& kl : kf.lines)
    {
      const Eigen::Vector3d a = kf.T_map_camera * kl.line.a, b = kf.T_map_camera * kl.line.b;
      const ic::ViewOffset off = ic::measureViewOffset(kf.T_map_camera.translation(), a, b, segments);
      if (off.edge < 0)
        continue;
      const std::string range = off.range_m < 2.0   ? "<2m"
                                : off.range_m < 3.0 ? "2-3m"
                                : off.range_m < 4.0 ? "3-4m"
                                                    : ">4m";
      const std::string angle = off.ray_angle_deg < 30.0 ? "<30deg" : off.ray_angle_deg < 60.0 ? "30-60deg" : ">60deg";
      for (const std::string& key : {std::string("all"), "kind " + edges[off.edge].kind, "range " + range,
                                     "ray " + angle, edges[off.edge].kind + " " + range})
      {
        OffsetGroup& g = groups[key];
        g.depth_mm.push_back(1000.0 * off.depth_m);
        g.lateral_mm.push_back(1000.0 * off.lateral_m);
        const double sigma = std::hypot(kl.line.sigma_m, kl.line.sigma_systematic_m);
        g.sigma_mm.push_back(1000.0 * sigma);
        g.shared_mm.push_back(1000.0 * kl.line.sigma_systematic_m);
        g.ratio.push_back(sigma > 0.0 ? std::abs(off.depth_m) / sigma : 0.0);
      }
    }
  printOffsetGroups("truth-observations", groups);
}

// The used map lines against the true edges: the offset split by their observations' interpretation planes (depth:
// in the planes, lateral: normal to them), and against their predicted sigma.
void reportMapLinesAgainstTruth(const std::vector<ic::simulation::TrueEdge>& edges,
                                const std::vector<ic::Segment3d>& segments, const ic::Survey& survey)
{
  std::map<std::string, OffsetGroup> groups;
  const std::vector<double> sigmas = survey.mapLineSigmas();
  const std::vector<ic::MapLine> used = survey.usedMapLines();
  for (size_t i = 0; i < used.size(); ++i)
  {
    const ic::MapLine& line = used[i];
    const ic::Line3dError e = ic::measureLine3d(line.a(), line.b(), segments, 0.05, 5.0);
    if (e.edge < 0)
      continue;
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    for (const auto& o : line.observations)
      normal += normal.dot(o.normal) < 0.0 ? -o.normal : o.normal;
    const ic::Segment3d& t = segments[e.edge];
    const Eigen::Vector3d u = (t.b - t.a).normalized(), m = 0.5 * (line.a() + line.b());
    const Eigen::Vector3d off = (m - t.a) - (m - t.a).dot(u) * u;
    const double lateral = normal.norm() > 0.0 ? off.dot(normal.normalized()) : 0.0;
    const double depth = std::sqrt(std::max(0.0, off.squaredNorm() - lateral * lateral));
    for (const std::string& key : {std::string("all"), "kind " + edges[e.edge].kind})
    {
      OffsetGroup& g = groups[key];
      g.depth_mm.push_back(1000.0 * depth);
      g.lateral_mm.push_back(1000.0 * lateral);
      g.sigma_mm.push_back(1000.0 * sigmas[i]);
      g.ratio.push_back(sigmas[i] > 0.0 ? off.norm() / sigmas[i] : 0.0);
    }
  }
  printOffsetGroups("truth-maplines", groups);
}

// Per calibrated camera the localiser's limit at it, and per pair of calibrated cameras their relative pose's error.
// The limit needs each keyframe's localiser error (keyframeLocalizationErrors).
void reportMapAgainstTruth(const std::vector<std::string>& truth_dirs, const ic::Survey& survey)
{
  const std::string& truth_dir = truth_dirs.front();
  const auto errors = keyframeLocalizationErrors(truth_dirs, survey);
  std::vector<Eigen::Vector3d> pivots;
  for (const auto& kf : survey.keyframes())
    pivots.push_back(kf.T_map_camera.translation());
  if (errors)
    reportKeyframesAgainstTruth(*errors, survey);
  std::vector<std::pair<std::string, ic::CameraPose>> found, truths;
  for (const auto& name : survey.cameraNames())
  {
    const auto& calibration = survey.camera(name).calibration();
    const auto truth = ic::loadCalibrationFile(truth_dir + "/" + name + ".yaml");
    if (!calibration || !truth)
      continue;
    found.push_back({name, calibration->camera.pose()});
    truths.push_back({name, truth->camera.pose()});
    if (errors)
    {
      const auto limit = ic::simulation::placementLimit(*errors, pivots, truth->camera.pose().center());
      std::printf("truth-limit %s %.2f mm %.4f deg\n", name.c_str(), 1000.0 * limit.position_m,
                  limit.rotation_rad * 180.0 / M_PI);
    }
  }
  for (size_t i = 0; i < found.size(); ++i)
    for (size_t j = i + 1; j < found.size(); ++j)
    {
      // Camera j's centre in camera i's frame, and the rotation from j to i.
      auto relative = [&](const ic::CameraPose& a, const ic::CameraPose& b) {
        return std::make_pair(Eigen::Vector3d(a.rotation * (b.center() - a.center())),
                              Eigen::Matrix3d(a.rotation * b.rotation.transpose()));
      };
      const auto [p, r] = relative(found[i].second, found[j].second);
      const auto [pt, rt] = relative(truths[i].second, truths[j].second);
      const double angle = Eigen::AngleAxisd(r * rt.transpose()).angle() * 180.0 / M_PI;
      std::printf("truth-relative %s %s %.2f mm %.4f deg\n", found[i].first.c_str(), found[j].first.c_str(),
                  1000.0 * (p - pt).norm(), angle);
    }
}

// The too-uncertain RGB-D lines of one edge ("truth-uncertain-edge"): how many keyframes, their predicted error
// sigma_m and range, their real offset from the edge (the larger of the end points') against sigma_m, and what
// their inverse-variance mean would be off (the fusion of LineMapOptions::max_fusion_sigma_m).
void printUncertainObservations(const ic::Survey& survey, const ic::Segment3d& part)
{
  std::vector<double> sigmas, ranges, offsets, ratios;
  std::set<double> stamps;
  const Eigen::Vector3d d = (part.b - part.a).normalized();
  auto off = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d r = p - part.a;
    return Eigen::Vector3d(r - r.dot(d) * d);
  };
  Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
  double information = 0.0;
  for (const auto& kf : survey.keyframes())
    for (const auto& l : kf.lines)
    {
      const ic::Segment3d line{kf.T_map_camera * l.line.a, kf.T_map_camera * l.line.b};
      if (!ic::segmentHoldsEdge(part, 0.0, part.length(), line, 0.03) || !(l.line.sigma_m > 0.0))
        continue;
      const Eigen::Vector3d oa = off(line.a), ob = off(line.b);
      const double offset = std::max(oa.norm(), ob.norm());
      sigmas.push_back(l.line.sigma_m);
      ranges.push_back(l.line.range_m);
      offsets.push_back(offset);
      ratios.push_back(offset / l.line.sigma_m);
      stamps.insert(kf.stamp);
      const double w = 1.0 / (l.line.sigma_m * l.line.sigma_m);
      weighted += w * 0.5 * (oa + ob);
      information += w;
    }
  auto median = [](std::vector<double> v) {
    if (v.empty())
      return std::nan("");
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  auto maximum = [](const std::vector<double>& v) {
    return v.empty() ? std::nan("") : *std::max_element(v.begin(), v.end());
  };
  std::printf(
      "truth-uncertain-edge %.2f m: %zu lines from %zu keyframes, sigma_m median %.1f max %.1f mm, range median "
      "%.1f m, offset median %.1f max %.1f mm, offset/sigma median %.2f max %.2f, inverse-variance mean %.1f mm off "
      "(predicted %.1f)\n",
      part.length(), sigmas.size(), stamps.size(), 1000.0 * median(sigmas), 1000.0 * maximum(sigmas), median(ranges),
      1000.0 * median(offsets), 1000.0 * maximum(offsets), median(ratios), maximum(ratios),
      information > 0.0 ? 1000.0 * (weighted / information).norm() : NAN,
      information > 0.0 ? 1000.0 / std::sqrt(information) : NAN);
}

// Why the map lacks an edge a fixed camera shows (issue 11's diagnosis): never in the Xtion's view (at a height no
// mount has in view within the depth range, or one a route could have brought into view), in view without
// depth (beyond its range, or grazing), or with depth and lost on the way to the map: no keyframe made a 3D line of
// it, its keyframes' lines were all too uncertain for the map (LineMapOptions::max_sigma_m), or the map holds it
// but leaves it out (support, spread) or holds it more than 1 cm off.
std::string missingCause(const ic::simulation::EdgeSightings& sight, const ic::Survey& survey,
                         const ic::Segment3d& part, double max_range_m, const std::vector<ic::XtionView>& xtions)
{
  if (sight.in_view == 0)
  {
    const double z = 0.5 * (part.a.z() + part.b.z()) - survey.options().floor.floor_height_m;
    const bool out_of_mount = !xtions.empty() && std::none_of(xtions.begin(), xtions.end(), [&](const auto& x) {
      return z <= x.highestInReach(max_range_m) && z >= x.lowestInReach(max_range_m);
    });
    return out_of_mount ? "never-in-view-mount" : "never-in-view";
  }
  if (sight.with_depth == 0)
    return sight.nearest_range_m > max_range_m ? "no-depth-range" : "no-depth-grazing";
  const double length = part.length();
  int observed = 0, certain = 0;
  for (const auto& kf : survey.keyframes())
    for (const auto& l : kf.lines)
    {
      const ic::Segment3d line{kf.T_map_camera * l.line.a, kf.T_map_camera * l.line.b};
      if (!ic::segmentHoldsEdge(part, 0.0, length, line, 0.03))
        continue;
      ++observed;
      certain += l.line.sigma_m <= survey.options().map.max_sigma_m ? 1 : 0;
    }
  if (observed == 0)
    return "depth-not-extracted";
  if (certain == 0)
  {
    printUncertainObservations(survey, part);
    return "depth-too-uncertain";
  }
  const auto& all = survey.lineMap().lines();
  auto held = [&](double distance) {
    return std::any_of(all.begin(), all.end(), [&](const ic::MapLine& m) {
      return ic::segmentHoldsEdge(part, 0.0, length, {m.a(), m.b()}, distance);
    });
  };
  return held(0.01) ? "map-not-used" : held(0.03) ? "map-off-1-3cm" : "map-merge-lost";
}

// Per missing image line its cause and per cause the share of the camera's image lines (truth-missing lines).
void diagnoseMissingEdges(const ic::simulation::World& world, const ic::Survey& survey, const std::string& name,
                          const ic::MapCoverage& coverage)
{
  std::vector<ic::Segment3d> parts;
  std::vector<const ic::CoverageLine*> lines;
  for (const auto& d : coverage.details)
    if (d.edge >= 0 && !d.covered)
    {
      parts.push_back(d.shown);
      lines.push_back(&d);
    }
  std::vector<Eigen::Isometry3d> poses;
  for (const auto& kf : survey.keyframes())
    poses.push_back(kf.T_map_camera);
  const auto sightings = ic::simulation::sightSegments(world, parts, poses);
  const auto xtions = ic::xtionViewsOf(survey.keyframes(), survey.options().floor.floor_height_m);
  std::map<std::string, double> by_cause;
  for (size_t i = 0; i < parts.size(); ++i)
  {
    const std::string cause = missingCause(sightings[i], survey, parts[i], world.xtion.depth.max_range_m, xtions);
    by_cause[cause] += lines[i]->length_px;
    const auto& a = parts[i].a;
    const auto& b = parts[i].b;
    std::printf(
        "truth-missing-line %s %.0f px [%.2f %.2f %.2f] -> [%.2f %.2f %.2f] in view %d with depth %d "
        "nearest %.1f m: %s\n",
        name.c_str(), lines[i]->length_px, a.x(), a.y(), a.z(), b.x(), b.y(), b.z(), sightings[i].in_view,
        sightings[i].with_depth, sightings[i].nearest_range_m, cause.c_str());
  }
  std::printf("truth-missing %s (%% of %.0f px):", name.c_str(), coverage.total_px);
  std::printf(" covered %.1f, on no true edge %.1f", 100.0 * coverage.covered_px / coverage.total_px,
              100.0 * (coverage.total_px - coverage.on_edge_px) / coverage.total_px);
  for (const auto& [cause, px] : by_cause)
    std::printf(", %s %.1f", cause.c_str(), 100.0 * px / coverage.total_px);
  std::printf("\n");
}

// Why the final check's samples of the TRUE camera find no image edge: the map point is hidden from it in the world
// (the occlusion test missed the surface in front), or it is in view and lies on a true edge, where the true camera
// sees that edge within 1 px of the map point (too faint, or below the camera's resolution) or farther (the map
// line is off by up to 2 cm), or on none (the map line is off or false). "truth-check" lines.
struct CheckSampleCauses
{
  size_t samples = 0, on_edge = 0, hidden = 0, hidden_on_edge = 0, faint = 0, displaced = 0, off = 0;
};

CheckSampleCauses classifyCheckSamples(const std::vector<ic::EdgeSamples>& checked, const ic::CameraModel& truth,
                                       const cv::Mat& depth, const std::vector<ic::Segment3d>& edges)
{
  // The nearest point of a true edge within 2 cm, if any.
  const auto nearest_true_edge = [&](const Eigen::Vector3d& x) -> std::optional<Eigen::Vector3d> {
    std::optional<Eigen::Vector3d> best;
    double best_m = 0.02;
    for (const ic::Segment3d& e : edges)
    {
      const Eigen::Vector3d d = e.b - e.a;
      const double t = std::clamp((x - e.a).dot(d) / std::max(1e-12, d.squaredNorm()), 0.0, 1.0);
      const double m = (e.a + t * d - x).norm();
      if (m <= best_m)
      {
        best_m = m;
        best = e.a + t * d;
      }
    }
    return best;
  };
  CheckSampleCauses c;
  for (const ic::EdgeSamples& line : checked)
    for (size_t k = 0; k < line.points.size() && k < line.map_points.size(); ++k)
    {
      if (!line.countedAt(k))
        continue;
      ++c.samples;
      const Eigen::Vector3d x = truth.toCamera(line.map_points[k]);
      const int u = static_cast<int>(std::lround(line.points[k].x())),
                v = static_cast<int>(std::lround(line.points[k].y()));
      const float z = (u >= 0 && v >= 0 && u < depth.cols && v < depth.rows) ? depth.at<float>(v, u) : 0.0f;
      const bool hidden = z > 0.0f && z < x.z() - (0.03 + 0.02 * x.z());
      if (line.on_edge[k])
      {
        ++c.on_edge;
        c.hidden_on_edge += hidden ? 1 : 0;
        continue;
      }
      if (hidden)
      {
        ++c.hidden;
        continue;
      }
      const auto edge = nearest_true_edge(line.map_points[k]);
      const auto seen = edge ? truth.project(*edge) : std::nullopt;
      if (!edge)
        ++c.off;
      else if (seen && (*seen - line.points[k]).norm() > 1.0)
        ++c.displaced;
      else
        ++c.faint;
    }
  return c;
}

std::string describeError(const ic::CameraModel& camera, const ic::CameraModel& truth)
{
  const ic::CameraErrors e = ic::compareCameras(truth, camera);
  char buffer[100];
  std::snprintf(buffer, sizeof(buffer), "%.3f %%, %.3f deg, %.1f mm", 100.0 * std::abs(e.focal_relative),
                e.rotation_rad * 180.0 / M_PI, 1000.0 * e.center_m);
  return buffer;
}

// The final check's numbers of one camera and its verdict.
std::string describeAgreement(const ic::ImageExplanation& e, const ic::ImageExplanationOptions& o)
{
  char buffer[200];
  std::snprintf(buffer, sizeof(buffer),
                "%.1f %% on edges (chance %.1f %%, excess %.2f, %zu samples; isolated %.1f %% of %zu): %s",
                100 * e.overlay_agreement, 100 * e.overlay_chance, e.overlayExcess(), e.samples,
                100 * e.isolated_agreement, e.isolated_samples, ic::acceptExplanation(e, o) ? "passes" : "fails");
  return buffer;
}

void diagnoseFinalCheck(const ic::simulation::World& world, const ic::FixedCamera& camera,
                        const ic::SurfaceVoxels* occluders, const std::string& name, const ic::CameraModel& truth,
                        const std::vector<ic::Segment3d>& map, const std::vector<ic::Segment3d>& edges)
{
  std::vector<ic::EdgeSamples> checked;
  const ic::ImageExplanation e = camera.explain(truth, map, occluders, nullptr, &checked);
  const int w = camera.config().image_width, h = camera.config().image_height;
  ic::simulation::RenderOptions render;
  render.supersampling = 1;
  render.color = false;
  const auto view = ic::simulation::Renderer(world).render(ic::simulation::ViewCamera::fromModel(truth, w, h), render);
  const CheckSampleCauses c = classifyCheckSamples(checked, truth, view.depth, edges);
  const double n = std::max<size_t>(1, c.samples);
  const double on_visible =
      static_cast<double>(c.on_edge - c.hidden_on_edge) / std::max(1.0, n - c.hidden - c.hidden_on_edge);
  std::printf(
      "truth-check %s true camera: %s; isolated %.1f %% of %zu (%s); of its %zu counted samples %.1f %% on an edge, "
      "without one: hidden from it "
      "%.1f %%, in view on a true edge %.1f %% (within 1 px of it %.1f %%, farther %.1f %%), on none %.1f %%; on an "
      "edge where not hidden %.1f %%\n",
      name.c_str(), e.describe().c_str(), 100 * e.isolated_agreement, e.isolated_samples,
      ic::acceptExplanation(e, camera.options().explanation) ? "passes" : "fails", c.samples, 100.0 * c.on_edge / n,
      100.0 * c.hidden / n, 100.0 * (c.faint + c.displaced) / n, 100.0 * c.faint / n, 100.0 * c.displaced / n,
      100.0 * c.off / n, 100.0 * on_visible);
  const ic::ImageExplanationOptions& o = camera.options().explanation;
  const bool accepted = camera.calibration().has_value() && camera.lastResult();
  const auto& result = accepted ? camera.lastResult() : camera.lastRefused();
  if (!result || result->checked_map_lines.empty())
    return;
  // The verdict with the chance level 4 px beside every sample too (chance_mapped_radius 0), to see what measuring it
  // clear of other map lines changes.
  ic::ImageExplanationOptions beside_every_sample = o;
  beside_every_sample.chance_mapped_radius_px = 0.0;
  const auto verdict_beside_every_sample = [&](const ic::CameraModel& c) {
    return ic::acceptExplanation(camera.explain(c, map, occluders, nullptr, nullptr, &beside_every_sample),
                                 beside_every_sample)
               ? "passes"
               : "fails";
  };
  // And with the other rule for samples with a clear place on one side only (chance_needs_both_sides).
  ic::ImageExplanationOptions other_rule = o;
  other_rule.chance_needs_both_sides = !o.chance_needs_both_sides;
  const auto agreement_other_rule = [&](const ic::CameraModel& c) {
    return describeAgreement(camera.explain(c, map, occluders, nullptr, nullptr, &other_rule), other_rule);
  };
  const char* other = o.chance_needs_both_sides ? "either side clear" : "both sides clear";
  std::printf("truth-agreement %s %s result (%s): %s; chance 4 px beside every sample: %s; %s: %s\n", name.c_str(),
              accepted ? "accepted" : "refused", describeError(result->calibration.camera, truth).c_str(),
              describeAgreement(result->explanation, o).c_str(),
              verdict_beside_every_sample(result->calibration.camera), other,
              agreement_other_rule(result->calibration.camera).c_str());
  for (const ic::AlternativeCamera& alt : result->ambiguity.alternatives)
    std::printf("truth-agreement %s alternative (%s): %s; chance 4 px beside every sample: %s; %s: %s\n", name.c_str(),
                describeError(alt.calibration.camera, truth).c_str(),
                describeAgreement(camera.explain(alt.calibration.camera, map, occluders), o).c_str(),
                verdict_beside_every_sample(alt.calibration.camera), other,
                agreement_other_rule(alt.calibration.camera).c_str());
}

// Map coverage (line_evaluation.h): the camera's image lines, extracted from its median under the true distortion,
// by length on a true edge the used map holds within 1 cm; whatever the calibration's outcome. With a world file,
// also why the map lacks the others (diagnoseMissingEdges) and why the final check's samples of the true camera find
// no image edge (diagnoseFinalCheck).
void reportCoverageAgainstTruth(const std::string& truth_dir, const ic::Survey& survey, const std::string& name,
                                const std::vector<ic::Segment3d>& map, const std::string& world_file)
{
  const auto truth = ic::loadCalibrationFile(truth_dir + "/" + name + ".yaml");
  const auto edges = ic::simulation::loadTrueEdges(truth_dir + "/edges.yaml");
  if (!truth || !edges || survey.camera(name).imageCount() == 0)
    return;
  const auto lines =
      ic::extractImageLines(survey.camera(name).medianImage(), truth->camera, survey.options().cameras.image_lines);
  if (!lines)
    return;
  std::vector<std::vector<Eigen::Vector2d>> polylines;
  for (const auto& line : *lines)
    polylines.push_back(line.points);
  std::vector<ic::Segment3d> segments;
  for (const auto& e : *edges)
    segments.push_back({e.start, e.end});
  const ic::MapCoverage c = ic::measureMapCoverage(polylines, truth->camera, segments, map);
  // Within 3 and 10 cm too: whether the map lacks the edges or holds them a little off.
  const double c3 = ic::measureMapCoverage(polylines, truth->camera, segments, map, 0.03).fraction();
  const double c10 = ic::measureMapCoverage(polylines, truth->camera, segments, map, 0.1).fraction();
  std::printf(
      "truth-coverage %s %.1f %% of %.0f px (%zu of %zu lines; %.1f %% on a true edge; within 3 / 10 cm "
      "%.1f / %.1f %%)\n",
      name.c_str(), 100.0 * c.fraction(), c.total_px, c.covered_lines, c.lines,
      c.total_px > 0.0 ? 100.0 * c.on_edge_px / c.total_px : 0.0, 100.0 * c3, 100.0 * c10);
  if (world_file.empty())
    return;
  const auto world = ic::simulation::loadWorldFile(world_file);
  if (!world)
  {
    std::fprintf(stderr, "calibrate_survey: %s\n", world.error().describe().c_str());
    return;
  }
  if (c.total_px > 0.0)
    diagnoseMissingEdges(*world, survey, name, c);
  diagnoseFinalCheck(*world, survey.camera(name), survey.surfaces().get(), name, truth->camera, map, segments);
}

// The map lines of one kind (beyond depth: triangulated, ceiling, floor; fused) in use against the true edges:
// within 3 predicted sigmas, within 1 cm, on none ("truth-<label>" lines).
void reportSourceAgainstTruth(const std::string& truth_dir, const ic::Survey& survey,
                              const std::function<bool(const ic::MapLine&)>& chosen, const std::string& label)
{
  const auto edges = ic::simulation::loadTrueEdges(truth_dir + "/edges.yaml");
  if (!edges)
    return;
  std::vector<ic::Segment3d> segments;
  for (const auto& e : *edges)
    segments.push_back({e.start, e.end});
  size_t lines = 0, within_sigmas = 0, within_cm = 0, none = 0;
  for (const auto& line : survey.usedMapLines())
  {
    if (!chosen(line))
      continue;
    ++lines;
    const ic::Line3dError e = ic::measureLine3d(line.a(), line.b(), segments, 0.1, 5.0);
    none += e.edge < 0 ? 1 : 0;
    within_sigmas += e.edge >= 0 && e.distance_m <= 3.0 * line.sigma() ? 1 : 0;
    within_cm += e.edge >= 0 && e.distance_m <= 0.01 ? 1 : 0;
    std::printf(
        "truth-%s-line %.2f m long, %.1f m from the keyframes' mean: off its edge %.2f mm, predicted sigma "
        "%.2f mm, [%.2f %.2f %.2f] -> [%.2f %.2f %.2f], support %d\n",
        label.c_str(), line.length(), (0.5 * (line.a() + line.b()) - survey.mapPlacement().centre).norm(),
        e.edge >= 0 ? 1000.0 * e.distance_m : NAN, 1000.0 * line.sigma(), line.a().x(), line.a().y(), line.a().z(),
        line.b().x(), line.b().y(), line.b().z(), line.support);
  }
  std::printf(
      "truth-%s %zu lines: %zu within 3 predicted sigmas of a true edge, %zu within 1 cm, %zu on "
      "none (10 cm, 5 deg)\n",
      label.c_str(), lines, within_sigmas, within_cm, none);
}

// The oracle's data: the image lines matched under the true camera and, as variants, the same matches with the
// map lines replaced by their true edges (image-line errors only), with the image lines replaced by the true edges'
// images (map-line errors only) and with both.
struct OracleData
{
  const ic::CalibrationFile& truth;
  const std::vector<ic::Segment3d>& map;
  std::vector<std::vector<Eigen::Vector2d>> polylines;
  std::vector<ic::LineMatch> matches;
  std::vector<ic::Segment3d> edges;  // the true edges
  ic::CorrespondenceSet set, true_world, true_image, true_both;

  OracleData(const ic::CalibrationFile& truth, const std::vector<ic::Segment3d>& map) : truth(truth), map(map) {}
};

// The signed distances (px) of image points to the image of a 3D line under the true camera (empty when the line
// does not project).
std::vector<double> distancesToLineImage(const ic::CameraModel& t, const ic::Segment3d& e,
                                         const std::vector<Eigen::Vector2d>& points)
{
  std::vector<double> out;
  const auto ua = t.projectUndistorted(e.a), ub = t.projectUndistorted(e.b);
  if (!ua || !ub)
    return out;
  const Eigen::Vector2d ud = (*ub - *ua).normalized();
  const Eigen::Vector2d n(-ud.y(), ud.x());
  for (const auto& m2 : points)
  {
    const auto u = t.distortion().undistort(m2);
    const auto back = u ? t.distortion().distort(*ua + ud * ud.dot(*u - *ua)) : std::nullopt;
    out.push_back(back ? n.dot(m2 - *back) : 0.0);
  }
  return out;
}

// Drops the matches whose image line does not lie on the map line's true edge (within 1 px under the true camera):
// a neighbouring parallel edge can project within the matching threshold, and such a match is not the truth's.
void dropMatchesOffTheirEdge(OracleData& d)
{
  if (d.edges.empty())
    return;
  const size_t before = d.matches.size();
  const auto off = [&](const ic::LineMatch& m) {
    const ic::Segment3d& s = d.map[m.map_line];
    const int edge = ic::measureLine3d(s.a, s.b, d.edges, 0.1, 5.0).edge;
    if (edge < 0)
      return false;  // a map line off every edge: the map's error, which the oracle keeps
    const auto x = distancesToLineImage(d.truth.camera, d.edges[edge], d.polylines[m.image_line]);
    return std::any_of(x.begin(), x.end(), [](double v) { return std::abs(v) > 1.0; });
  };
  d.matches.erase(std::remove_if(d.matches.begin(), d.matches.end(), off), d.matches.end());
  if (d.matches.size() < before)
    std::printf("  oracle: %zu matches dropped, their image line off the map line's true edge\n",
                before - d.matches.size());
}

// The correspondences of the matches the true camera makes (tight thresholds), as the pipeline forms them.
ic::CorrespondenceSet oracleCorrespondences(OracleData& d, const ic::FixedCameraOptions& options)
{
  const int w = d.truth.image_width, h = d.truth.image_height;
  d.matches = ic::matchLines(d.map, d.polylines, d.truth.camera, w, h, 2.0, 3.0, options.matcher);
  dropMatchesOffTheirEdge(d);
  ic::CorrespondenceSet set;
  set.image_width = w;
  set.image_height = h;
  for (const auto& m : d.matches)
  {
    const auto interval = ic::visibleInterval(d.truth.camera, d.map[m.map_line], w, h);
    ic::LineCorrespondence c;
    c.image = d.polylines[m.image_line];
    for (int k = 0; k < options.matcher.world_points_per_line; ++k)
      c.world.push_back(d.map[m.map_line].pointAt(interval->first + (interval->second - interval->first) * k /
                                                                        (options.matcher.world_points_per_line - 1.0)));
    set.lines.push_back(c);
  }
  return set;
}

// Prints the signed distances (px) of line i's image points to its true edge's image.
void printImagePointDistances(const OracleData& d, size_t i, int edge)
{
  std::printf("    line %zu (image %zu, edge %d):", i, d.matches[i].image_line, edge);
  for (const double x : distancesToLineImage(d.truth.camera, d.edges[edge], d.set.lines[i].image))
    std::printf(" %+.3f", x);
  std::printf("\n");
}

// The true-3D and true-2D variants: each matched line's world points moved onto its true edge, its image points
// onto that edge's image.
void replaceByTruth(OracleData& d, bool details)
{
  const ic::CameraModel& t = d.truth.camera;
  d.true_world = d.true_image = d.true_both = d.set;
  for (size_t i = 0; i < d.set.lines.size(); ++i)
  {
    const ic::Segment3d& m = d.map[d.matches[i].map_line];
    const ic::Line3dError err = ic::measureLine3d(m.a, m.b, d.edges, 0.1, 5.0);
    if (err.edge < 0)
      continue;
    const ic::Segment3d& e = d.edges[err.edge];
    const Eigen::Vector3d dir = (e.b - e.a).normalized();
    for (auto& x : d.true_world.lines[i].world)
      x = e.a + dir * dir.dot(x - e.a);
    const auto ua = t.projectUndistorted(e.a), ub = t.projectUndistorted(e.b);
    if (!ua || !ub)
      continue;
    const Eigen::Vector2d ud = (*ub - *ua).normalized();
    if (details)
      printImagePointDistances(d, i, err.edge);
    for (auto& m2 : d.true_image.lines[i].image)
    {
      const auto u = t.distortion().undistort(m2);
      if (!u)
        continue;
      const auto back = t.distortion().distort(*ua + ud * ud.dot(*u - *ua));
      if (back)
        m2 = *back;
    }
  }
}

// The part of edge e that the image points' rays pass nearest (an edge along a whole building may reach behind the
// camera, and then has no image as a whole).
ic::Segment3d clippedToView(const ic::CameraModel& t, const ic::Segment3d& e,
                            const std::vector<Eigen::Vector2d>& points)
{
  const Eigen::Vector3d u = (e.b - e.a).normalized(), c = t.pose().center();
  auto nearest = [&](const Eigen::Vector2d& m) {
    const auto r = t.backProject(m);
    if (!r)
      return e.a;
    const Eigen::Vector3d v = (t.pose().rotation.transpose() * *r).normalized(), w = e.a - c;
    const double b = u.dot(v), denom = 1.0 - b * b;
    const double s = denom > 1e-12 ? (b * v.dot(w) - u.dot(w)) / denom : 0.0;
    return Eigen::Vector3d(e.a + s * u);
  };
  return {nearest(points.front()), nearest(points.back())};
}

// Per direction line: the true edge its image line shows and how far that edge's direction is from the one the
// line was given (a line given the wrong direction turns the camera: its residuals carry no map error to widen it).
void printDirectionLineTruth(const OracleData& d)
{
  const ic::CameraModel& t = d.truth.camera;
  const auto images = ic::projectEdges(t, d.edges);
  for (const auto& line : d.set.direction_lines)
  {
    const DirectionLineTruth truth = directionLineTruth(line, t, d.edges, images);
    const ic::ImageLineError& ie = truth.shown;
    std::string ends;
    if (ie.edge >= 0)
    {
      const auto distances = distancesToLineImage(t, clippedToView(t, d.edges[ie.edge], line.image), line.image);
      if (!distances.empty())
        ends = ", points " + std::to_string(distances.front()) + " .. " + std::to_string(distances.back()) + " px";
    }
    std::printf(
        "    direction line %zu pts %.1f px, direction %.3f %.3f %.3f (group %d): edge %d rms %.2f px, %.2f deg "
        "from the given direction%s\n",
        line.image.size(), (line.image.back() - line.image.front()).norm(), line.direction.x(), line.direction.y(),
        line.direction.z(), line.azimuth_group, ie.edge, ie.rms_px, truth.angle_deg, ends.c_str());
  }
}

// The unmatched image lines as the final calibration uses them (direction lines, the other long ones plumb lines,
// found under the true camera); then the both-true variant.
void addUnmatchedLinesAndBothTrue(OracleData& d, const ic::LineMatcherOptions& matcher, bool details)
{
  std::vector<ic::Segment3d> matched_map_lines;
  for (const auto& m : d.matches)
    matched_map_lines.push_back(d.map[m.map_line]);
  const auto directions =
      ic::knownDirectionsOf(matched_map_lines, matcher.horizontal_direction_lines, matcher.min_direction_support);
  std::vector<bool> taken;
  const auto direction_lines =
      ic::directionLinesOf(d.matches, d.polylines, d.truth.camera, directions, matcher.min_direction_line_px,
                           matcher.calibration.refinement.max_direction_line_px, &taken);
  const std::vector<bool> matched = ic::matchedImageLines(d.matches, d.polylines.size());
  for (auto* s2 : {&d.set, &d.true_world, &d.true_image, &d.true_both})
    s2->direction_lines = direction_lines;
  for (size_t i = 0; i < d.polylines.size(); ++i)
    if (!matched[i] && !taken[i] && d.polylines[i].size() >= 3 &&
        (d.polylines[i].back() - d.polylines[i].front()).norm() >= matcher.min_straight_line_px)
      for (auto* s2 : {&d.set, &d.true_world, &d.true_image, &d.true_both})
        s2->straight_lines.push_back(d.polylines[i]);
  if (details)
  {
    std::printf("    %zu plumb lines, %zu direction lines\n", d.set.straight_lines.size(), direction_lines.size());
    printDirectionLineTruth(d);
  }
  for (size_t i = 0; i < d.set.lines.size(); ++i)
  {
    d.true_both.lines[i].world = d.true_world.lines[i].world;
    d.true_both.lines[i].image = d.true_image.lines[i].image;
  }
}

// Per image line: its true edge, its match and the map lines of that edge.
void printImageLineDetails(const OracleData& d)
{
  const ic::CameraModel& t = d.truth.camera;
  const auto images = ic::projectEdges(t, d.edges);
  std::vector<int> map_edge(d.map.size(), -1);
  for (size_t j = 0; j < d.map.size(); ++j)
    map_edge[j] = ic::measureLine3d(d.map[j].a, d.map[j].b, d.edges, 0.1, 5.0).edge;
  for (size_t i = 0; i < d.polylines.size(); ++i)
  {
    const ic::ImageLineError ie = ic::measureImageLine(d.polylines[i], t.distortion(), images, 3.0, 1.0, 0.6);
    double length = 0.0;
    for (size_t k = 1; k < d.polylines[i].size(); ++k)
      length += (d.polylines[i][k] - d.polylines[i][k - 1]).norm();
    std::string maps;
    for (size_t j = 0; j < d.map.size(); ++j)
      if (ie.edge >= 0 && map_edge[j] == ie.edge)
      {
        const auto vis = ic::visibleInterval(t, d.map[j], d.truth.image_width, d.truth.image_height);
        char b[128];
        std::snprintf(b, sizeof(b), " m%zu(%.2fm%s)", j, (d.map[j].b - d.map[j].a).norm(), vis ? "" : ",invisible");
        maps += b;
      }
    std::string matched = "-";
    for (const auto& m : d.matches)
      if (m.image_line == i)
        matched = "m" + std::to_string(m.map_line) + " d=" + std::to_string(m.distance_px);
    std::printf("    image %2zu: %3zu pts %6.1f px, edge %3d rms %.2f px; match %s; map lines of the edge:%s\n", i,
                d.polylines[i].size(), length, ie.edge, ie.rms_px, matched.c_str(), maps.c_str());
  }
}

// Per match: the map line's support, visibility, weight, error against its true edge and spread.
void printMatchDetails(const OracleData& d, const std::vector<ic::MapLine>& map_lines)
{
  const ic::CameraModel& t = d.truth.camera;
  for (size_t i = 0; i < d.set.lines.size(); ++i)
  {
    const ic::MapLine& ml = map_lines[d.matches[i].map_line];
    const ic::Segment3d& m = d.map[d.matches[i].map_line];
    const ic::Line3dError err = ic::measureLine3d(m.a, m.b, d.edges, 0.1, 5.0);
    const auto vis = ic::visibleInterval(t, m, d.truth.image_width, d.truth.image_height);
    const double range = (0.5 * (m.a + m.b) - t.pose().center()).norm();
    std::printf(
        "    match image %zu map %zu: support %d, length %.2f m (visible %.0f %%), weight %.3g, edge %d off %.1f "
        "mm, %.2f deg, range %.2f m, image line %zu pts, spread %.1f mm\n",
        d.matches[i].image_line, d.matches[i].map_line, ml.support, ml.length(),
        vis ? 100.0 * (vis->second - vis->first) : 0.0, ml.weight, err.edge, 1000.0 * err.distance_m, err.angle_deg,
        range, d.set.lines[i].image.size(), 1000.0 * ml.spread());
  }
}

// Each variant calibrated like the pipeline does, against the truth.
void calibrateOracleVariants(const OracleData& d, const ic::FixedCameraOptions& options)
{
  const std::vector<std::pair<const char*, const ic::CorrespondenceSet*>> variants = {
      {"oracle", &d.set}, {"  true 3D", &d.true_world}, {"  true 2D", &d.true_image}, {"  both true", &d.true_both}};
  const ic::CameraModel& t = d.truth.camera;
  const int w = d.truth.image_width, h = d.truth.image_height;
  // The matcher's explanation score (lower is better) of the true camera: a pipeline result that scores lower than
  // it is one the matcher cannot tell from the truth by its score.
  std::printf("  explanation score of the true camera %.2f\n",
              ic::explanationScore(d.map, d.polylines, t, w, h, options.matcher));
  for (const auto& [label, data] : variants)
  {
    const auto calibration = ic::calibrateCamera(*data, options.matcher.calibration);
    if (!calibration)
    {
      std::printf("  %s: %zu matches, calibration failed: %s\n", label, d.matches.size(),
                  calibration.error().describe().c_str());
      continue;
    }
    const ic::CameraErrors e = ic::compareCameras(t, calibration->camera);
    const ic::CameraUncertainty& u = calibration->uncertainty;
    std::printf(
        "  %s: %zu matches (%zu inliers): focal %+.4f %%, pp %.2f px, lambda %.2f %%, rotation %.4f deg, position "
        "%.2f mm, RMS %.3f px; 1 sigma fx %.4f %%, lambda %.2f %%, rotation %.4f deg, position %.2f mm; explanation "
        "score %.2f\n",
        label, d.matches.size(), calibration->inlier_count, 100.0 * e.focal_relative, e.principal_point_px,
        100.0 * e.lambda_relative, e.rotation_rad * 180.0 / M_PI, 1000.0 * e.center_m, calibration->reprojection.rms_px,
        100.0 * u.fx / t.intrinsics().fx, 100.0 * u.lambda / std::abs(t.distortion().lambda), u.rotation_deg,
        1000.0 * u.position_m, ic::explanationScore(d.map, d.polylines, calibration->camera, w, h, options.matcher));
  }
}

// Diagnostic: the image lines matched under the true camera (tight thresholds), calibrated like the pipeline does,
// and the variants with true 3D lines, true image lines and both.
void oracleCalibration(const std::string& truth_dir, const std::string& name, const ic::FixedCamera& camera,
                       const std::vector<ic::Segment3d>& map, const ic::FixedCameraOptions& survey_options,
                       const std::vector<ic::MapLine>& map_lines, bool details)
{
  ic::FixedCameraOptions options = survey_options;
  options.matcher = camera.matcherOptions();  // with the prior's principal point, as the camera calibrates
  const auto truth = ic::loadCalibrationFile(truth_dir + "/" + name + ".yaml");
  if (!truth)
    return;
  const auto lines = ic::extractImageLines(camera.medianImage(), truth->camera.distortion(), options.image_lines);
  if (!lines)
    return;
  OracleData d(*truth, map);
  for (const auto& l : *lines)
    d.polylines.push_back(l.points);
  if (const auto edges = ic::simulation::loadTrueEdges(truth_dir + "/edges.yaml"))
    for (const auto& e : *edges)
      d.edges.push_back({e.start, e.end});
  d.set = oracleCorrespondences(d, options);
  replaceByTruth(d, details);
  addUnmatchedLinesAndBothTrue(d, options.matcher, details);
  if (details)
  {
    printImageLineDetails(d);
    printMatchDetails(d, map_lines);
  }
  calibrateOracleVariants(d, options);
}

std::vector<double> numbers(const std::string& list)
{
  std::vector<double> out;
  std::stringstream in(list);
  std::string item;
  while (std::getline(in, item, ','))
    out.push_back(std::strtod(item.c_str(), nullptr));
  return out;
}

// A prior from the true camera, off by exactly the given amounts in random directions.
std::optional<ic::CameraPrior> priorFromTruth(const std::string& truth_dir, const std::string& name,
                                              const ic::CameraPrior& configured, const std::vector<double>& offsets,
                                              const std::vector<double>& sigmas, std::mt19937& rng)
{
  const auto truth = ic::loadCalibrationFile(truth_dir + "/" + name + ".yaml");
  if (!truth)
    return std::nullopt;
  std::normal_distribution<double> normal;
  const auto randomUnit = [&]() {
    Eigen::Vector3d v(normal(rng), normal(rng), normal(rng));
    return Eigen::Vector3d(v.normalized());
  };
  ic::CameraPrior prior = configured;
  const Eigen::Isometry3d world_from_camera = truth->camera.pose().worldFromCamera();
  prior.position = world_from_camera.translation() + offsets[0] * randomUnit();
  // The viewing direction turned by D about a random axis across it; the roll (rotation about the viewing
  // direction, which an installer knows: the image rows are level) stays the true one.
  const Eigen::Matrix3d truth_rotation = world_from_camera.linear();
  const Eigen::Vector3d forward = truth_rotation.col(2);
  Eigen::Vector3d axis = randomUnit();
  axis = (axis - axis.dot(forward) * forward).normalized();
  prior.direction = Eigen::AngleAxisd(offsets[1] * M_PI / 180.0, axis) * forward;
  if (const auto level = ic::opticalRotationLookingAlong(forward))
    prior.roll_deg =
        std::atan2(truth_rotation.col(0).dot(level->col(1)), truth_rotation.col(0).dot(level->col(0))) * 180.0 / M_PI;
  const double fx = truth->camera.intrinsics().fx;
  const double sign = std::uniform_int_distribution<int>(0, 1)(rng) ? 1.0 : -1.0;
  prior.horizontal_fov_deg = 2.0 * std::atan(0.5 * truth->image_width / fx) * 180.0 / M_PI * (1.0 + sign * offsets[2]);
  if (sigmas.size() == 3)
  {
    prior.position_sigma_m = sigmas[0];
    prior.direction_sigma_deg = sigmas[1];
    prior.fov_sigma_relative = sigmas[2];
  }
  return prior;
}

double seconds(std::chrono::steady_clock::time_point start)
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The survey's parameters as calibration_node reads them (survey/survey_parameters.h), from --params or else the
// --cameras file, then the command line's flags, which win; false (after saying why) on a malformed value.
// --depth-registration X,Y; false (after saying why) when malformed. auto and estimate are done after parsing
// (estimateDepthRegistration).
bool parseDepthRegistration(const ic::CommandLine& cli, ic::SurveyOptions* options)
{
  const std::string mode = cli.value("depth-registration", "");
  if (mode.empty() || mode == "auto" || mode == "estimate")
    return true;
  const std::vector<double> v = numbers(cli.value("depth-registration"));
  if (v.size() != 2 || !(std::abs(v[0]) <= 10.0 && std::abs(v[1]) <= 10.0))
  {
    std::cerr << "calibrate_survey: --depth-registration takes X,Y (px, each within +-10), auto or estimate\n";
    return false;
  }
  options->rgbd.sampler.registration_offset_px = Eigen::Vector2d(v[0], v[1]);
  return true;
}

// --depth-registration-sigma PX.
bool parseRegistrationSigma(const ic::CommandLine& cli, ic::SurveyOptions* options)
{
  if (!cli.has("depth-registration-sigma"))
    return true;
  const std::vector<double> v = numbers(cli.value("depth-registration-sigma"));
  if (v.size() != 1 || !(v[0] >= 0.0 && v[0] <= 10.0))
  {
    std::cerr << "calibrate_survey: --depth-registration-sigma takes one value in px, 0 .. 10\n";
    return false;
  }
  options->rgbd.sampler.registration_sigma_px = v[0];
  return true;
}

// --depth-registration's mode: as given; else auto, unless the parameters gave the offset (a sensor measured once,
// whose value must not be overridden by a survey's estimate).
std::string registrationMode(const ic::CommandLine& cli, bool parameters_give_registration)
{
  if (cli.has("depth-registration"))
    return cli.value("depth-registration");
  return parameters_give_registration ? "given" : "auto";
}

// --depth-registration auto | estimate: the offset from the bags' RGB-D frames (a first pass; one Xtion), printed;
// auto puts it in the options (left at 0,0 when refused). False when a bag cannot be read.
bool estimateDepthRegistration(const std::vector<std::string>& bags, const ic::SurveyBagOptions& bag_options,
                               bool cli_sets_registration_sigma, ic::SurveyOptions* options)
{
  const ic::RgbdLineExtractor extractor(options->rgbd);
  ic::DepthRegistrationEstimator estimator;
  size_t failed = 0;
  for (const std::string& bag : bags)
    if (const auto read = ic::readSurveyRgbdFrames(
            bag, bag_options,
            [&](const ic::RgbdFrame& frame) { failed += estimator.addFrame(frame, extractor) ? 0 : 1; });
        !read)
    {
      std::cerr << "calibrate_survey: " << read.error().message() << "\n";
      return false;
    }
  const auto e = estimator.estimate();
  if (!e)
  {
    std::printf("depth registration: not estimated (%s); using %.3f,%.3f px\n", e.error().message().c_str(),
                options->rgbd.sampler.registration_offset_px.x(), options->rgbd.sampler.registration_offset_px.y());
    return true;
  }
  std::printf(
      "depth registration: estimated %.3f,%.3f px (1 sigma %.3f, %.3f px) from %zu creases (%zu observations, "
      "%zu trimmed) in %zu frames (%zu unusable), scatter %.2f\n",
      e->offset_px.x(), e->offset_px.y(), e->sigma_px.x(), e->sigma_px.y(), e->creases, e->observations, e->trimmed,
      e->frames, failed, e->scatter);
  options->rgbd.sampler.registration_offset_px = e->offset_px;
  if (!cli_sets_registration_sigma)
    options->rgbd.sampler.registration_sigma_px = e->sigma_px.maxCoeff();
  return true;
}

// --name 0|1: an option that switches something on or off (any non-zero number is on).
bool onOff(ic::CommandLine& cli, const std::string& name, bool current)
{
  return cli.number(name, current ? 1.0 : 0.0) != 0.0;
}

// The options of each fixed camera's calibration: its final check and its matching.
void parseCameraOptions(ic::CommandLine& cli, ic::FixedCameraOptions* cameras)
{
  cameras->explanation.plain_floor_by_sample =
      onOff(cli, "plain-floor-samples", cameras->explanation.plain_floor_by_sample);
  cameras->explanation.plain_ceiling = onOff(cli, "plain-ceiling-samples", cameras->explanation.plain_ceiling);
  cameras->matcher.calibration.refinement.single_focal =
      onOff(cli, "square-pixels", cameras->matcher.calibration.refinement.single_focal);
  cameras->explanation.texture.min_neighbours = static_cast<size_t>(
      cli.number("texture-min-neighbours", static_cast<double>(cameras->explanation.texture.min_neighbours), 0, 100));
  cameras->explanation.min_gradient = cli.number("overlay-min-gradient", cameras->explanation.min_gradient, 0.1, 255.0);
  cameras->explanation.faint_edge_gradient =
      cli.number("faint-edge-gradient", cameras->explanation.faint_edge_gradient, 0.0, 255.0);
  cameras->explanation.chance_mapped_radius_px =
      cli.number("chance-mapped-radius", cameras->explanation.chance_mapped_radius_px, 0.0, 10.0);
  cameras->explanation.chance_needs_both_sides =
      onOff(cli, "chance-both-sides", cameras->explanation.chance_needs_both_sides);
  ic::LineMatcherOptions& matcher = cameras->matcher;
  if (cli.flag("no-refine"))
    matcher.calibration.refine = false;
  if (cli.flag("no-ransac"))
    matcher.calibration.ransac = false;
  matcher.search_starts = static_cast<int>(cli.number("search-starts", matcher.search_starts));
  matcher.local_search_starts = static_cast<int>(cli.number("local-search-starts", matcher.local_search_starts));
  matcher.hypothesis_starts = static_cast<int>(cli.number("hypothesis-starts", matcher.hypothesis_starts, 0, 64));
  matcher.hypothesis_centres = static_cast<int>(cli.number("hypothesis-centres", matcher.hypothesis_centres, 1, 200));
  matcher.prior_start = onOff(cli, "prior-start", matcher.prior_start);
  cameras->ambiguity.neighbourhood_share =
      cli.number("ambiguity-neighbourhood", cameras->ambiguity.neighbourhood_share, 0.0, 0.5);
  cameras->ambiguity.better_score_margin =
      cli.number("ambiguity-better-score", cameras->ambiguity.better_score_margin, 0.0, 100.0);
  if (cli.flag("trace"))
    matcher.trace = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
}

// registration_given: whether the parameters set depth_registration/x_px or y_px.
bool parseSurveyOptions(ic::CommandLine& cli, ic::SurveyOptions* options, bool* registration_given)
{
  auto parameters = ic::YamlParameterSource::load(cli.value("params", cli.value("cameras")));
  if (!parameters)
  {
    std::cerr << "calibrate_survey: " << parameters.error().describe() << "\n";
    return false;
  }
  *registration_given = ic::depthRegistrationGiven(*parameters);
  *options = ic::readSurveyParameters(*parameters, *options);
  for (const std::string& error : parameters->errors())
    std::cerr << "calibrate_survey: " << error << "\n";
  if (!parameters->ok())
    return false;
  if (!parseDepthRegistration(cli, options) || !parseRegistrationSigma(cli, options))
    return false;
  options->min_map_support = static_cast<int>(cli.number("min-support", options->min_map_support));
  options->max_map_spread_m = cli.number("max-spread", options->max_map_spread_m);
  if (cli.has("odometry-sigma"))
  {
    const std::vector<double> v = numbers(cli.value("odometry-sigma"));
    if (v.size() != 4)
    {
      std::cerr << "calibrate_survey: --odometry-sigma takes M,PER_M,DEG,PER_DEG\n";
      return false;
    }
    options->adjustment.odometry_sigma_m = v[0];
    options->adjustment.odometry_sigma_per_m = v[1];
    options->adjustment.odometry_sigma_deg = v[2];
    options->adjustment.odometry_sigma_per_deg = v[3];
  }
  if (cli.has("localization-sigma"))
  {
    const std::vector<double> v = numbers(cli.value("localization-sigma"));
    if (v.size() < 2 || v.size() > 3)
    {
      std::cerr << "calibrate_survey: --localization-sigma takes M,DEG[,TAU]\n";
      return false;
    }
    options->localization_sigma_m = v[0];
    options->localization_sigma_deg = v[1];
    if (v.size() == 3)
      options->localization_correlation_s = v[2];
  }
  options->floor.enabled = onOff(cli, "floor-lines", options->floor.enabled);
  options->floor.floor_height_m = cli.number("floor-height", options->floor.floor_height_m);
  options->floor.max_range_m = cli.number("floor-max-range", options->floor.max_range_m);
  const bool extended = onOff(cli, "floor-extended", options->floor.depth_confirmation);
  options->floor.depth_confirmation = options->floor.extend_confirmed = extended;

  options->map.max_fusion_sigma_m = cli.number("max-fusion-sigma", options->map.max_fusion_sigma_m);
  options->map.min_fusion_keyframes =
      static_cast<int>(cli.number("min-fusion-keyframes", options->map.min_fusion_keyframes));
  options->map.fusion_floor_m = cli.number("fusion-floor", options->map.fusion_floor_m);
  options->map.depth_step_sigmas = cli.number("depth-step-sigmas", options->map.depth_step_sigmas);
  options->rgbd.sampler.slant_allowance = onOff(cli, "depth-slant-allowance", options->rgbd.sampler.slant_allowance);
  options->ceiling.enabled = onOff(cli, "ceiling-lines", options->ceiling.enabled);
  options->triangulated.enabled = onOff(cli, "triangulated-lines", options->triangulated.enabled);
  options->extended_retry.enabled = onOff(cli, "extended-retry", options->extended_retry.enabled);
  options->triangulated.repetition_px =
      cli.number("triangulated-repetition-px", options->triangulated.repetition_px, 0.0, 100.0);
  options->occlusion.enabled = onOff(cli, "occlusion-test", options->occlusion.enabled);
  options->occlusion.follow_adjustment =
      onOff(cli, "occluders-follow-adjustment", options->occlusion.follow_adjustment);
  options->occlusion.other_surface_margin_m =
      cli.number("occlusion-other-surface-margin", options->occlusion.other_surface_margin_m, 0.0, 1.0);
  parseCameraOptions(cli, &options->cameras);
  if (!cli.error().empty())
  {
    std::cerr << "calibrate_survey: " << cli.error() << "\n\n" << kUsage;
    return false;
  }
  return true;
}

// --principal-point-from-truth SIGMA_PX[,SEED]: every prior knows its camera's principal point, the true one moved by
// a normal error of SIGMA_PX per axis, with that sigma (as from a lab calibration of the camera).
bool principalPointsFromTruth(const ic::CommandLine& cli, std::vector<ic::FixedCameraConfig>* cameras)
{
  const std::vector<double> values = numbers(cli.value("principal-point-from-truth"));
  if (values.empty() || values.size() > 2 || !(values[0] > 0.0) || !cli.has("truth-dir"))
  {
    std::cerr << "calibrate_survey: --principal-point-from-truth needs SIGMA_PX[,SEED] (SIGMA_PX > 0) and "
                 "--truth-dir\n";
    return false;
  }
  std::mt19937 rng(values.size() == 2 ? static_cast<unsigned>(values[1]) : 0u);
  std::normal_distribution<double> error(0.0, values[0]);
  for (ic::FixedCameraConfig& camera : *cameras)
  {
    if (!camera.prior)
      continue;
    const auto truth = ic::loadCalibrationFile(truthDir(cli) + "/" + camera.name + ".yaml");
    if (!truth)
    {
      std::cerr << "calibrate_survey: no truth for " << camera.name << "\n";
      return false;
    }
    const ic::Intrinsics& k = truth->camera.intrinsics();
    camera.prior->principal_point = Eigen::Vector2d(k.cx + error(rng), k.cy + error(rng));
    camera.prior->principal_point_sigma_px = values[0];
    if (!cli.flag("quiet"))
      std::printf("%s: principal point known: %.1f %.1f px (true %.1f %.1f), sigma %.1f px\n", camera.name.c_str(),
                  camera.prior->principal_point->x(), camera.prior->principal_point->y(), k.cx, k.cy, values[0]);
  }
  return true;
}

// The configured cameras, with --prior-from-truth's priors and --principal-point-from-truth's principal points;
// false (after saying why) when one cannot be made.
bool loadCameras(const ic::CommandLine& cli, std::vector<ic::FixedCameraConfig>* cameras,
                 std::map<std::string, std::string>* camera_of_topic)
{
  const auto configs = ic::loadCameraConfig(cli.value("cameras"));
  if (!configs)
  {
    std::cerr << "calibrate_survey: " << configs.error().describe() << "\n";
    return false;
  }
  std::mt19937 rng(0);
  std::vector<double> prior_offsets;
  if (cli.has("prior-from-truth"))
  {
    prior_offsets = numbers(cli.value("prior-from-truth"));
    if (prior_offsets.size() == 4)
      rng.seed(static_cast<unsigned>(prior_offsets[3]));
    if (prior_offsets.size() < 3 || !cli.has("truth-dir"))
    {
      std::cerr << "calibrate_survey: --prior-from-truth needs P,D,F[,SEED] and --truth-dir\n";
      return false;
    }
  }
  for (const auto& entry : *configs)
  {
    cameras->push_back(entry.camera);
    (*camera_of_topic)[entry.camera.image_topic] = entry.camera.name;
    if (prior_offsets.empty() || !entry.camera.prior)
      continue;
    const auto prior = priorFromTruth(truthDir(cli), entry.camera.name, *entry.camera.prior, prior_offsets,
                                      numbers(cli.value("prior-sigmas")), rng);
    if (!prior)
    {
      std::cerr << "calibrate_survey: no truth for " << entry.camera.name << "\n";
      return false;
    }
    cameras->back().prior = *prior;
    if (!cli.flag("quiet"))
      std::printf("%s: prior from the truth at %.3f %.3f %.3f, direction %.3f %.3f %.3f, roll %.2f deg, fov %.2f deg\n",
                  entry.camera.name.c_str(), prior->position.x(), prior->position.y(), prior->position.z(),
                  prior->direction.x(), prior->direction.y(), prior->direction.z(), prior->roll_deg,
                  prior->horizontal_fov_deg);
  }
  return !cli.has("principal-point-from-truth") || principalPointsFromTruth(cli, cameras);
}

void printSurveySummary(const ic::Survey& survey, size_t frames_without_pose, double survey_s)
{
  const ic::SurveyStats& stats = survey.stats();
  const size_t used = survey.mapSegments().size();
  std::printf(
      "survey: %zu RGB-D frames, %zu keyframes, %zu 3D lines, %zu map lines (%zu seen %d+ times), %zu "
      "frames without a pose; %.1f s\n",
      stats.frames, stats.keyframes, stats.lines, survey.lineMap().size(), used, survey.options().min_map_support,
      frames_without_pose, survey_s);
  if (stats.adjusted_observations > 0)
    std::printf(
        "map adjustment: %zu observations (%zu dropped), keyframes moved by RMS %.1f mm, %.3f deg; "
        "%zu map lines (%zu used); %.2f s CPU\n",
        stats.adjusted_observations, stats.dropped_observations, 1000.0 * stats.mean_correction_m,
        stats.mean_correction_deg, survey.lineMap().size(), used, 1e-3 * stats.adjustment_cpu_ms);
  if (const auto reach = ic::depthLineReach(survey.keyframes(), survey.options().map.max_sigma_m))
    std::printf(
        "depth lines: most of them precise enough for the map (%.1f mm) within %.2f m of the Xtion (the "
        "survey hints' reach)\n",
        1000.0 * survey.options().map.max_sigma_m, *reach);
  if (survey.options().floor.enabled)
  {
    size_t floor_lines = 0;
    for (const auto& line : survey.usedMapLines())
      floor_lines += line.source == ic::MapLineSource::kFloor ? 1 : 0;
    std::printf("floor lines: %zu candidates (%zu refused: depth off the floor), %zu floor map lines used\n",
                stats.floor_candidates, stats.floor_refused, floor_lines);
  }
  if (survey.options().ceiling.enabled)
  {
    size_t ceiling = 0;
    for (const auto& line : survey.usedMapLines())
      ceiling += line.source == ic::MapLineSource::kCeiling ? 1 : 0;
    const auto plane =
        ic::measureCeilingHeight(survey.keyframes(), survey.options().ceiling, survey.options().floor.floor_height_m);
    std::printf("ceiling lines: plane at %.4f m (sigma %.2f mm, %d depth lines), %zu map lines used\n",
                plane ? plane->height_m : NAN, plane ? 1000.0 * plane->sigma_m : NAN, plane ? plane->lines : 0,
                ceiling);
  }
  if (survey.options().triangulated.enabled)
  {
    size_t triangulated = 0;
    for (const auto& line : survey.usedMapLines())
      triangulated += line.source == ic::MapLineSource::kTriangulated ? 1 : 0;
    std::printf("triangulated lines: %zu map lines used\n", triangulated);
  }
  if (survey.options().map.max_fusion_sigma_m > 0.0)
  {
    ic::LineMap::FusionCounts n;
    survey.lineMap().fusedLines(&n);
    std::printf(
        "fused lines: %zu uncertain map lines, %zu from enough keyframes, %zu precise enough, %zu consistent, %zu "
        "not held by a precise line (used)\n",
        n.pool, n.keyframes, n.sigma, n.consistent, n.used);
  }
}

// A refusal with what to survey next (survey_guidance.h), and its picture beside the overlay.
void reportRefusal(const ic::CommandLine& cli, const ic::Survey& survey, const std::string& name,
                   const std::vector<ic::Segment3d>& map, const ic::Error& error)
{
  const ic::SurveyGuidanceOptions options = ic::surveyGuidanceOptions(
      survey.keyframes(), survey.options().floor.floor_height_m, survey.options().map.max_sigma_m);
  const auto guidance = ic::guideSurvey(survey.camera(name), map, survey.options().cameras.image_lines, options);
  if (!guidance)
  {
    std::printf("%s: FAILED: %s (no survey guidance: %s)\n", name.c_str(), error.describe().c_str(),
                guidance.error().message().c_str());
    return;
  }
  std::printf("%s: FAILED: %s\n", name.c_str(), ic::describeRefusal(error, *guidance).c_str());
  const ic::CalibrationStore store(cli.value("out-dir"));
  const cv::Mat hint = ic::drawSurveyHint(survey.camera(name).medianImage(), *guidance);
  if (const ic::Status saved = store.saveSurveyHint(name, hint); !saved)
    std::printf("%s: %s\n", name.c_str(), saved.error().describe().c_str());
  else
    std::printf("%s: survey hint (%zu of %zu cells without map lines) -> %s\n", name.c_str(),
                guidance->count(ic::GuidanceCell::kUnmapped), guidance->cells.size(),
                store.surveyHintPath(name).c_str());
  const std::string text = ic::surveyHintYaml(ic::surveyHintOf(name, *guidance));
  if (const ic::Status saved = store.saveSurveyHintYaml(name, text); !saved)
    std::printf("%s: %s\n", name.c_str(), saved.error().describe().c_str());
}

// The camera's report beside its calibration (a refused result's too, saying why); a failure is only printed.
void writeReport(const ic::CommandLine& cli, ic::Survey& survey, const std::string& name,
                 const std::vector<ic::Segment3d>& map, const ic::FixedCameraResult& result, const std::string& refusal)
{
  if (cli.flag("no-report"))
    return;
  ic::CalibrationReport report =
      ic::fixedCameraReport(survey.camera(name).config(), result, survey.camera(name).medianImage(), map,
                            ic::ReportSurveySummary{survey.stats().keyframes, map.size()});
  if (!refusal.empty())
  {
    report.accepted = false;
    report.verdict = refusal;
  }
  const auto files = ic::writeCalibrationReport(cli.value("out-dir"), report);
  if (!files)
    std::printf("%s: %s\n", name.c_str(), files.error().describe().c_str());
  else if (!cli.flag("quiet"))
    std::printf("%s: report %s\n", name.c_str(), files->html.c_str());
}

// Calibrates one camera and writes its calibration, overlay and report; false when the calibration failed or was not
// saved.
bool calibrateAndSave(const ic::CommandLine& cli, ic::Survey& survey, const std::string& name,
                      const std::vector<ic::Segment3d>& map)
{
  const auto calibration_start = std::chrono::steady_clock::now();
  ic::FixedCamera& camera = survey.camera(name);
  const auto result = survey.calibrate(name, cli.value("world-frame", "map"));
  if (!result)
  {
    reportRefusal(cli, survey, name, map, result.error());
    if (camera.lastRefused())
      writeReport(cli, survey, name, map, *camera.lastRefused(), result.error().describe());
    if (cli.has("truth-dir") && camera.lastRefused())
      reportRefusedAgainstTruth(truthDir(cli), name, *camera.lastRefused());
    return false;
  }
  const ic::CalibrationStore store(cli.value("out-dir"));
  const cv::Mat overlay =
      ic::drawCalibrationOverlay(camera.medianImage(), result->file.image_width, result->file.image_height,
                                 result->file.camera, map, result->matched_image_lines);
  if (const ic::Status saved = store.save(name, result->file, overlay); !saved)
  {
    std::printf("%s: %s\n", name.c_str(), saved.error().describe().c_str());
    return false;
  }
  std::printf("%s: %s (%.1f s) -> %s\n", name.c_str(), result->summary.c_str(), seconds(calibration_start),
              store.calibrationPath(name).c_str());
  if (const std::string saved_sigma = result->file.quality ? ic::describeSavedSigma(result->file.quality->extra) : "";
      !saved_sigma.empty())
    std::printf("%s: %s\n", name.c_str(), saved_sigma.c_str());
  writeReport(cli, survey, name, map, *result, "");
  if (cli.has("truth-dir"))
  {
    ic::RefinementOptions refinement = survey.camera(name).matcherOptions().calibration.refinement;
    refinement.estimate_distortion = result->calibration.distortion_estimated;
    reportAgainstTruth(truthDir(cli), name, *result, refinement);
    reportLocalPlacementAgainstTruth(cli.items("truth-dir"), survey, name, *result);
  }
  return true;
}

// Every selected camera calibrated (or, with --oracle, the oracle's diagnostics); the exit status.
int calibrateCameras(const ic::CommandLine& cli, ic::Survey& survey)
{
  const std::vector<ic::Segment3d> map = survey.mapSegments();
  const auto selected = [&](const std::string& name) { return !cli.has("camera") || cli.value("camera") == name; };
  int status = 0;
  for (const auto& name : survey.cameraNames())
    if (selected(name) && !cli.flag("oracle") && !calibrateAndSave(cli, survey, name, map))
      status = 1;
  if (cli.has("truth-dir"))
  {
    for (const auto& name : survey.cameraNames())
      if (selected(name))
        reportCoverageAgainstTruth(truthDir(cli), survey, name, map, cli.value("coverage-diagnosis"));
    auto of = [](ic::MapLineSource source) { return [source](const ic::MapLine& l) { return l.source == source; }; };
    const std::string truth_dir = truthDir(cli);
    if (survey.options().triangulated.enabled)
      reportSourceAgainstTruth(truth_dir, survey, of(ic::MapLineSource::kTriangulated), "triangulated");
    if (survey.options().ceiling.enabled)
      reportSourceAgainstTruth(truth_dir, survey, of(ic::MapLineSource::kCeiling), "ceiling");
    if (survey.options().floor.enabled)
      reportSourceAgainstTruth(truth_dir, survey, of(ic::MapLineSource::kFloor), "floor");
    if (survey.options().map.max_fusion_sigma_m > 0.0)
      reportSourceAgainstTruth(
          truth_dir, survey, [](const ic::MapLine& l) { return l.fused; }, "fused");
    reportMapAgainstTruth(cli.items("truth-dir"), survey);
    if (const auto edges = ic::simulation::loadTrueEdges(truthDir(cli) + "/edges.yaml"))
    {
      std::vector<ic::Segment3d> segments;
      for (const auto& e : *edges)
        segments.push_back({e.start, e.end});
      reportObservationsAgainstTruth(*edges, segments, survey);
      reportMapLinesAgainstTruth(*edges, segments, survey);
    }
  }
  if (cli.flag("oracle") && cli.has("truth-dir"))
    for (const auto& name : survey.cameraNames())
      if (selected(name))
      {
        std::printf("%s:\n", name.c_str());
        oracleCalibration(truthDir(cli), name, survey.camera(name), map, survey.options().cameras,
                          survey.usedMapLines(), cli.flag("oracle-details"));
      }
  return status;
}

// The options taking a value and the flags (kUsage explains each).
const std::set<std::string> kValueOptions = {"cameras",
                                             "params",
                                             "out-dir",
                                             "world-frame",
                                             "min-support",
                                             "camera",
                                             "search-starts",
                                             "local-search-starts",
                                             "prior-start",
                                             "ambiguity-neighbourhood",
                                             "hypothesis-starts",
                                             "hypothesis-centres",
                                             "truth-dir",
                                             "coverage-diagnosis",
                                             "prior-from-truth",
                                             "prior-sigmas",
                                             "principal-point-from-truth",
                                             "max-spread",
                                             "localization-sigma",
                                             "odom-frame",
                                             "odometry-sigma",
                                             "floor-lines",
                                             "depth-registration",
                                             "depth-registration-sigma",
                                             "floor-height",
                                             "floor-max-range",
                                             "floor-extended",
                                             "occlusion-test",
                                             "plain-floor-samples",
                                             "plain-ceiling-samples",
                                             "texture-min-neighbours",
                                             "overlay-min-gradient",
                                             "faint-edge-gradient",
                                             "square-pixels",
                                             "chance-mapped-radius",
                                             "chance-both-sides",
                                             "occlusion-other-surface-margin",
                                             "occluders-follow-adjustment",
                                             "triangulated-lines",
                                             "triangulated-repetition-px",
                                             "ceiling-lines",
                                             "extended-retry",
                                             "max-fusion-sigma",
                                             "min-fusion-keyframes",
                                             "fusion-floor",
                                             "depth-step-sigmas",
                                             "depth-slant-allowance"};
const std::set<std::string> kFlagOptions = {"no-refine", "no-ransac",      "no-report", "quiet",
                                            "oracle",    "oracle-details", "trace",     "no-odometry"};
}  // namespace

int main(int argc, char** argv)
{
  ic::quietSolverLogging();
  ic::CommandLine cli(argc, argv, kValueOptions, kFlagOptions);
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  if (!cli.error().empty() || cli.positional().empty() || !cli.has("cameras") || !cli.has("out-dir"))
  {
    std::cerr << "calibrate_survey: "
              << (cli.error().empty() ? "BAG, --cameras and --out-dir are required" : cli.error()) << "\n\n"
              << kUsage;
    return 2;
  }
  if (const size_t dirs = cli.items("truth-dir").size(); dirs > 1 && dirs != cli.positional().size())
  {
    std::cerr << "calibrate_survey: --truth-dir gives " << dirs << " folders for " << cli.positional().size()
              << " bags: give one per bag, in their order, or one\n";
    return 2;
  }
  ic::SurveyOptions options;
  std::vector<ic::FixedCameraConfig> cameras;
  ic::SurveyBagOptions bag_options;
  bool registration_given = false;
  if (!parseSurveyOptions(cli, &options, &registration_given) ||
      !loadCameras(cli, &cameras, &bag_options.camera_of_topic))
    return 2;
  bag_options.world_frame = cli.value("world-frame", "map");
  bag_options.odom_frame = cli.flag("no-odometry") ? "" : cli.value("odom-frame", "odom");
  if (const std::string mode = registrationMode(cli, registration_given); mode == "auto" || mode == "estimate")
  {
    if (!estimateDepthRegistration(cli.positional(), bag_options, cli.has("depth-registration-sigma"), &options))
      return 2;
    if (mode == "estimate")
      return 0;
  }
  ic::Survey survey(cameras, options);
  const auto start = std::chrono::steady_clock::now();
  size_t frames_without_pose = 0;
  for (const std::string& bag : cli.positional())  // several: recordings of one survey, in order
  {
    survey.startRecording();
    const auto read = ic::readSurveyBag(bag, bag_options, &survey);
    if (!read)
    {
      std::cerr << "calibrate_survey: " << read.error().message() << "\n";
      return 2;
    }
    frames_without_pose += read->frames_without_pose;
  }
  if (!cli.flag("quiet"))
    printSurveySummary(survey, frames_without_pose, seconds(start));
  return calibrateCameras(cli, survey);
}
