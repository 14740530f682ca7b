// What to survey next when a camera is refused: which parts of its view hold image lines that no map line explains,
// and where on the floor the robot should drive and look so that its Xtion maps them.
//
// The view is cut into a coarse grid of cells. Each image line is sampled every few pixels; a sample is explained
// when a map line, projected through the best camera available (the refused result's, else the prior's), passes
// within the tolerance. A cell is
//   unmapped  it holds image-line samples and most of them are unexplained (structure the map lacks),
//   empty     it holds neither image lines nor projected map lines,
//   covered   otherwise.
// Neighbouring unmapped cells form a region. The floor a region looks at: each of its cells' rays (a 3 x 3 grid of
// pixels per cell) meets the floor plane z = 0; a ray that does not meet it within max_range_m (or leaves the
// map's extent first: the bounding box of every map line, widened by map_margin_m) stops there, at floor height.
// The region's floor polygon is the convex hull of these points: the surfaces the region shows stand on it or at
// its far edge. The robot is sent to stand robot_standoff_m before the polygon's centroid (on the line from the
// camera's foot, or at the foot when the centroid is nearer), moved inside the map lines' extent by
// robot_clearance_m, looking towards the centroid, so that the Xtion (depth up to about 5 m) sees those surfaces
// within 1 to 4 m.
//
// With the Xtion's views known (XtionView per mount, from the survey's keyframes) the standpoint is chosen for the
// region's structure instead: each ray's point is also given a height (where it meets the floor, or its height where
// it leaves the map's extent: a wall), and the standpoint is the one from which the Xtion, at one of its mounts'
// heights and pitches, has most of those points in its view within xtion_reach_m (the survey's own depth lines' reach
// for the map, depthLineReach, where the keyframes show one): standoffs from min_standoff_m to
// max_standoff_m, from the camera's side or, where the robot has been, from any side (of the nearly best, the
// closest to the fixed standpoint). A region no one standpoint has mostly in view (a whole view placed by the prior,
// from under the camera to its far wall, against a depth reach of under 3 m) is cut in halves of its cells, each
// with its own standpoint, while that brings more of its lines into view (split_below_share). A low Xtion tilted down
// sees a wall's upper part only from afar, and from nowhere within its depth's reach when the wall is high: when most
// of a region's points are at heights no mount of the survey has in view (xtionHeightShare() below min_xtion_share) the
// sentence says how high (low) the Xtion sees and what to do for another drive: the mount (the pitch at the Xtion's
// height, else the nearest height within limits with its pitch) that brings the region's heights (up to the camera's
// own, for a region above the Xtion) into its view within reach (UnmappedRegion::mountToSee; for a wall too high for
// that, the mount pitched to the limit that adds a useful part of it), else a mount beyond the limits, or CAD lines.
// The points are where the rays meet the floor or the map's extent: furniture in front of them is not known, so the
// heights are lower bounds (a ray that descends meets a desk above the floor it would reach), and for a region below
// the Xtion the sentence says "if".
#ifndef INSITU_CALIBRATION_SURVEY_SURVEY_GUIDANCE_H
#define INSITU_CALIBRATION_SURVEY_SURVEY_GUIDANCE_H

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/lines/image_lines.h"
#include "insitu_calibration/map/line_map_adjustment.h"

namespace insitu_calibration
{
class FixedCamera;

// What the survey's Xtion sees: its optical centre's height above the floor, its optical axis' pitch (above the
// horizontal; negative: tilted down) and its half fields of view.
struct XtionView
{
  double height_m = 0.0;
  double pitch_deg = 0.0;
  double vertical_half_fov_deg = 0.0;
  double horizontal_half_fov_deg = 0.0;
  // The highest and lowest heights above the floor it has in view within `reach_m` of its optical centre, 2 deg
  // inside its field of view.
  double highestInReach(double reach_m) const;
  double lowestInReach(double reach_m) const;
  // The pitch (deg) at which it would have every height from low_m to high_m in view within reach_m: of the pitches
  // that do, the nearest to its own, 3 deg inside them (their middle when they span less than 6 deg); nullopt when
  // no pitch does at its height.
  std::optional<double> pitchToSee(double low_m, double high_m, double reach_m) const;
};

// The mounts the guidance may advise (a robot's mast allows a range of heights; a pan-tilt a range of pitches).
struct XtionMountLimits
{
  double min_height_m = 0.3;
  double max_height_m = 1.5;
  double max_abs_pitch_deg = 45.0;
};

// A mount the guidance advises: the Xtion's height above the floor and its pitch (above the horizontal, deg), and
// whether the height is a new one (else the survey's mount's, re-pitched).
struct XtionMount
{
  double height_m = 0.0;
  double pitch_deg = 0.0;
  bool new_height = false;
};

// The Xtion's views in the survey's keyframes, one per mount (the Xtion re-pitched or moved between recordings or
// during one): the keyframes grouped where their pitches (sorted) jump by more than 2 deg or their heights by more
// than 5 cm, each group of at least a twentieth of them (and 3) a mount, with its keyframes' median height above the
// floor (z = floor_height_m) and pitch and field of view (from the image size and focal length); ordered by pitch.
// Empty without keyframes.
std::vector<XtionView> xtionViewsOf(const std::vector<Keyframe>& keyframes, double floor_height_m);

// Where the robot has been: the keyframes' Xtion positions (x, y), thinned to one per 0.25 m of the path.
std::vector<Eigen::Vector2d> visitedPositions(const std::vector<Keyframe>& keyframes);

// How far from the Xtion the survey's depth lines are precise enough for the map (Line3d::sigma_m within
// max_sigma_m, LineMapOptions), as the survey itself shows it: their ranges in 0.25 m bands from 1 m out, the start
// of the first band (of at least kMinReachBandLines lines) in which fewer than half are; none where every band up to
// the farthest line is precise enough (the scene ends before the depth's precision does). The Xtion's noise grows
// as z^2: on generated buildings most lines beyond about 3 m are too uncertain for the map (docs/measurements.md).
constexpr size_t kMinReachBandLines = 10;
std::optional<double> depthLineReach(const std::vector<Keyframe>& keyframes, double max_sigma_m);

struct SurveyGuidanceOptions
{
  int columns = 8;
  int rows = 6;
  // A sample within this distance of a projected map line is explained: for a camera from a (refused) result, and,
  // as a share of the image width, for the prior's camera (which may be 10 degrees off).
  double tolerance_px = 12.0;
  double prior_tolerance_width_fraction = 0.08;
  double sample_step_px = 3.0;
  // A cell needs this many samples (of line length in px / sample_step_px) to count as holding image lines, and
  // this share of them unexplained to be unmapped.
  int min_samples = 8;
  double min_unexplained_share = 0.6;
  double max_range_m = 10.0;
  double map_margin_m = 0.5;
  double robot_standoff_m = 2.0;
  double robot_clearance_m = 0.4;  // the robot stands at least this far inside the map lines' extent
  size_t max_regions = 6;          // the largest regions (by unexplained image lines) are kept
  // The Xtion's views, one per mount the survey was driven at (xtionViewsOf), when known: the standoff is chosen so
  // that one of them sees the region's structure (above), and a region is out of reach only when every mount misses
  // it. Empty: not known.
  std::vector<XtionView> xtions;
  // Its depth lines are precise enough for the map within about this range (surveyGuidanceOptions: the survey's own,
  // depthLineReach, where it shows one).
  double xtion_reach_m = 4.0;
  double min_standoff_m = 1.0;
  double max_standoff_m = 6.0;
  // Where the robot has been (visitedPositions): a standpoint off the line from the camera's foot must lie within
  // visited_radius_m of one, so that it is free floor on this side of the walls. Empty: anywhere in the map's
  // extent.
  std::vector<Eigen::Vector2d> visited;
  double visited_radius_m = 1.0;
  // The camera's height (map z) when known apart from the camera the guidance projects through (guideSurvey: the
  // installer's prior, as a refused result may be wrong); else that camera's.
  std::optional<double> camera_height_m;
  // The operator turns the robot about this much either side of the look direction (the simulator's visit does).
  double look_sweep_deg = 30.0;
  // Below this share of the region's points at heights the Xtion can see (from anywhere), the region is out of its
  // reach.
  double min_xtion_share = 0.5;
  // The mounts a region out of reach may be advised (UnmappedRegion::mountToSee).
  XtionMountLimits mount_limits;
  // With the Xtion's views known, a region whose standpoint has less than split_below_share of its points in the
  // Xtion's view (a whole view placed by a prior, from under the camera to the far wall) is cut in two halves of its
  // cells, across the image's rows or its columns (the cut with the larger gain), each half with its own standpoint,
  // when the halves' shares, weighted by their image lines, exceed the region's by at least min_split_gain; at most
  // max_region_parts parts of one region.
  double split_below_share = 0.5;
  double min_split_gain = 0.15;
  int max_region_parts = 4;
};

// The options with what the survey's keyframes tell of it: the Xtion's mounts (xtionViewsOf), where the robot has
// been (visitedPositions) and its depth lines' reach (depthLineReach, where they show one); the rest as given.
SurveyGuidanceOptions surveyGuidanceOptions(const std::vector<Keyframe>& keyframes, double floor_height_m,
                                            double max_sigma_m, SurveyGuidanceOptions options = {});

enum class GuidanceCell
{
  kCovered,
  kUnmapped,
  kEmpty
};

struct UnmappedRegion
{
  std::vector<int> cells;                      // row * columns + column
  std::string where;                           // "left", "top right", "centre", ... of the view
  size_t image_lines = 0;                      // image lines mostly unexplained whose samples are mostly here
  std::vector<Eigen::Vector2d> floor_polygon;  // map frame, z = 0, counter-clockwise
  Eigen::Vector2d robot_position = Eigen::Vector2d::Zero();   // map frame
  Eigen::Vector2d look_direction = Eigen::Vector2d::UnitX();  // unit, map frame
  // The height range (m above the floor) of what the region shows (its rays' points: lower bounds, as a ray meets
  // furniture or a wall's upper part before the floor or the map's edge), and the camera's own height.
  double structure_min_height_m = 0.0;
  double structure_max_height_m = 0.0;
  double camera_height_m = 0.0;
  // With the Xtion's views known: the share of those points one of them sees from the standpoint (-1: not
  // computed), and the shares that no mount has in view within its reach, wherever it stands: higher than the lowest
  // mount's highest height (above every view, or between two), or lower than anything in view.
  double xtion_share = -1.0;
  double xtion_above_share = 0.0;
  double xtion_below_share = 0.0;
  double xtion_reach_m = 0.0;  // the reach and views the shares were computed for
  std::vector<XtionView> xtions;
  // The mount a new pitch is advised from: for a region above, the one that sees highest; below, the one that sees
  // lowest.
  XtionView xtion;
  double xtionHeightShare() const { return 1.0 - xtion_above_share - xtion_below_share; }
  bool outOfXtionReach(double min_share) const { return xtion_share >= 0.0 && xtionHeightShare() < min_share; }
  XtionMountLimits mount_limits;  // SurveyGuidanceOptions::mount_limits
  // The mount at which the Xtion has the region's heights in view within its reach (pitch in whole degrees, height in
  // tenths of a metre when it changes): for a region above it up to the camera's own height if a mount does that,
  // else up to the region's highest point; failing both, only the heights no mount of the survey has in view (its
  // recordings keep the rest). The Xtion's own height first, then the nearest heights within mount_limits (higher for
  // a region above, lower below), pitches within them. Where none does, the first mount pitched to the limit that
  // adds at least kMinAdvisedBandM of the heights no mount has in view (the rest stays out of reach: the sentence
  // says what it then has in view). None when no such mount does it or the view is unknown.
  std::optional<XtionMount> mountToSee() const;

private:
  // The mount at height_m pitched to have low_m .. high_m in view within reach, when a pitch within the limits does.
  std::optional<XtionMount> mountWithin(double height_m, double low_m, double high_m) const;
};

// A mount that adds less of a region's heights than this is not advised (mountToSee).
constexpr double kMinAdvisedBandM = 0.5;

struct SurveyGuidance
{
  int width = 0;
  int height = 0;
  int columns = 0;
  int rows = 0;
  std::vector<GuidanceCell> cells;        // row-major
  std::vector<UnmappedRegion> regions;    // largest first
  cv::Rect cellRect(int cell) const;      // the pixels of a cell
  size_t count(GuidanceCell kind) const;  // cells of a kind
  // "survey the left part of the view (or: the whole view): 12 image lines there have no map line; drive the robot to
  // about (2.1, 3.4) in the map and look towards (0.71, -0.71)", one clause per region joined by "; also ", or empty
  // without regions. A region out of the Xtion's reach (SurveyGuidanceOptions::min_xtion_share) adds what to do
  // about the mount.
  std::string sentence() const;
  double min_xtion_share = 0.5;  // SurveyGuidanceOptions::min_xtion_share, for sentence() and the hint picture
};

// The guidance from the image lines (distorted px), the map lines and a camera (distortion included).
// tolerance_px: see SurveyGuidanceOptions.
SurveyGuidance computeSurveyGuidance(const CameraModel& camera, int width, int height,
                                     const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                     const std::vector<Segment3d>& map_lines, double tolerance_px,
                                     const SurveyGuidanceOptions& options = {});

// The guidance for a fixed camera after a refusal: its median image's lines (extracted with the camera's
// distortion) against the map, through the refused result's camera if the refusal came that far, else the camera's
// current one (its calibration or its prior, with the prior's wider tolerance). Errors: no camera (neither prior
// nor calibration), no image, the extraction failed.
Expected<SurveyGuidance> guideSurvey(const FixedCamera& camera, const std::vector<Segment3d>& map_lines,
                                     const ImageLineOptions& image_line_options,
                                     const SurveyGuidanceOptions& options = {});

// The region's floor polygon as triangles (a fan: the polygon is convex) at a height, for a triangle-list marker.
std::vector<Eigen::Vector3d> floorTriangles(const UnmappedRegion& region, double height_m = 0.02);

// The refusal's text with the guidance's sentence appended ("<error>. What to do: <sentence>"), or the error alone;
// for a view too weakly determined (kDegenerate) that is mapped already where it has image lines (at most an eighth
// of those cells unmapped), also what helps instead of more of the same survey.
std::string describeRefusal(const Error& error, const SurveyGuidance& guidance);

// The image (grey or colour; black canvas when empty) with the unmapped cells shaded orange and numbered by
// region, the empty cells darkened, and a legend.
cv::Mat drawSurveyHint(const cv::Mat& image, const SurveyGuidance& guidance);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_SURVEY_GUIDANCE_H
