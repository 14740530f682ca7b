// Map lines on the floor beyond the depth range: a 2D line of the Xtion's RGB image that has no depth-based 3D line,
// lies below the horizon and whose end-point rays meet the floor plane (z = floor_height_m in the map) within
// max_range_m becomes a candidate by ray-plane intersection. Its predicted error grows with the square of the range
// over the camera's height (the grazing angle): the 2D edge's pixel noise and the mount's tilt and height errors
// propagated along the ray, the pixel noise also across it.
//
// A candidate becomes a map line only when candidates from at least min_keyframes keyframes agree within their
// predicted errors and their offsets across the line do not follow their cameras' offsets: an edge at height e
// seen from height h lands on the floor shifted by e / (h - e) times the camera's move across it, so the slope of
// that regression tells an edge min_edge_height_m above the floor (a table's edge, a skirting board's top) from the
// floor at confirm_sigmas. Candidates whose segment has depth that disagrees with the floor are refused at
// extraction, and a floor line that a depth map line already holds (over half its extent) is left out. A line seen
// only from one offset across it (along a straight leg of the route) leaves the slope unresolved: optionally
// (depth_confirmation, extend_confirmed) its depth or a confirmed floor line it continues confirms it instead.
#ifndef INSITU_CALIBRATION_MAP_FLOOR_LINES_H
#define INSITU_CALIBRATION_MAP_FLOOR_LINES_H

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "insitu_calibration/lines/depth_sampler.h"
#include "insitu_calibration/lines/line_map.h"
#include "insitu_calibration/lines/rgbd_frame.h"
#include "insitu_calibration/map/line_map_adjustment.h"

namespace insitu_calibration
{
struct FloorLineOptions
{
  // Off by default: on the default world (seeds 1-2) the cameras moved by small amounts both ways (cam_desk's
  // lambda 1.18 -> 1.77 %, cam_east's focal -0.009 -> +0.030 % on seed 1 while its rotation went 0.036 -> 0.008 deg).
  bool enabled = false;
  double floor_height_m = 0.0;    // the floor plane's z in the map frame
  double max_range_m = 12.0;      // end points farther from the camera (horizontally) are not used
  double min_length_m = 0.2;      // on the floor
  double pixel_sigma_px = 0.3;    // the RGB segments' end points across the line
  double tilt_sigma_deg = 0.05;   // the mount's pitch and roll (a floor not quite level, the robot rocking)
  double height_sigma_m = 0.003;  // the camera's height above the floor
  // Depth along the segment that disagrees with the floor by more than depth_tolerance_m + depth_tolerance_per_m2
  // z^2 on more than half of the samples refuses the candidate (at least min_depth_samples samples: else no depth).
  double depth_tolerance_m = 0.02;
  double depth_tolerance_per_m2 = 0.006;
  int min_depth_samples = 5;
  // Confirmation: candidates within merge_sigmas of each other (their random errors, plus merge_floor_m) and
  // max_angle_deg join one line; it is kept when seen from min_keyframes keyframes and the slope test (above) puts
  // it nearer the floor than min_edge_height_m / 2, resolved at confirm_sigmas.
  double merge_sigmas = 3.0;
  double merge_floor_m = 0.01;
  double max_angle_deg = 2.0;
  double max_gap_m = 0.3;
  int min_keyframes = 2;
  double min_edge_height_m = 0.1;
  double confirm_sigmas = 3.0;
  double max_sigma_m = 0.1;  // confirmed lines predicted to be worse are dropped
  // Confirmation by depth (off by default, see README): a line seen only from about one offset across it (along a
  // straight leg of the route) leaves the slope unresolved; it is confirmed when the depth of its segment put it on
  // the floor in at least min_depth_keyframes keyframes (depth samples along an unlifted segment that agree with
  // the floor, or a depth line too uncertain for the map with both ends within min_edge_height_m / 2 of the floor)
  // and the slope is not off the floor's 0 by more than confirm_sigmas. Such depth lines become candidates too.
  bool depth_confirmation = false;
  int min_depth_keyframes = 2;
  // An unresolved line that is not clearly off the floor and continues a confirmed one (parallel, both ends within
  // merge_sigmas of it) is confirmed too: the part of a long floor edge seen only along the route beside the part
  // seen across it (off by default).
  bool extend_confirmed = false;
};

// A candidate on the floor plane (map frame).
struct FloorCandidate
{
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Vector3d sensor = Eigen::Vector3d::Zero();
  double sigma_random_m = 0.0;      // pixel noise, across the line (differs between keyframes)
  double sigma_systematic_m = 0.0;  // tilt and height, across the line (shared by nearby keyframes)
  int keyframe = 0;
  bool depth_on_floor = false;  // its observation's depth put it on the floor
};

// What a segment's depth (samples along it, in the camera's optical frame) says: on the floor (at least
// min_depth_samples samples, half of them within the depth tolerance of the floor), off it, or too few samples.
enum class FloorDepth
{
  kUnknown,
  kOnFloor,
  kOffFloor
};
FloorDepth floorDepthOf(const std::vector<DepthSample>& samples, const RgbdCamera& camera,
                        const Eigen::Isometry3d& T_map_camera, const FloorLineOptions& options);

// Whether a segment's depth agrees with the floor, or has too few samples to tell (floorDepthOf is not kOffFloor).
bool depthAgreesWithFloor(const std::vector<DepthSample>& samples, const RgbdCamera& camera,
                          const Eigen::Isometry3d& T_map_camera, const FloorLineOptions& options);

// Whether a segment (map frame) lies on the floor z = floor_height_m: both ends within tolerance_m of it.
bool segmentOnFloor(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double floor_height_m, double tolerance_m);

// Whether a depth line (map frame) lies on the floor: both ends within min_edge_height_m / 2 of it.
bool depthLineOnFloor(const Line3d& line, const FloorLineOptions& options);

// The candidate of one observation under a camera pose; false when a ray misses the floor within max_range_m or the
// segment is shorter than min_length_m on the floor.
bool intersectFloor(const FloorObservation& observation, const Eigen::Isometry3d& T_map_camera, double focal_px,
                    const FloorLineOptions& options, FloorCandidate* candidate);

// Whether one of `others` already holds the line: parallel (max_angle_deg), within the line's 3 sigma or 3 cm, and
// covering at least half of its extent (a line that reaches well beyond the other's end is kept: the part the other
// did not reach).
bool heldByMapLine(const MapLine& line, const std::vector<MapLine>& others, double max_angle_deg);

// The confirmed floor lines of the keyframes (their floor observations under the corrected poses; corrections empty
// or one per keyframe) that no depth map line of `depth_lines` already holds. MapLine::source is kFloor,
// MapLine::sigma() their predicted error, MapLine::support the number of candidates.
std::vector<MapLine> confirmFloorLines(const std::vector<Keyframe>& keyframes,
                                       const std::vector<PoseCorrection>& corrections,
                                       const std::vector<MapLine>& depth_lines, const FloorLineOptions& options);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MAP_FLOOR_LINES_H
