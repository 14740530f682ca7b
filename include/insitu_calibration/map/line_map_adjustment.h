// The line map as a multi-view reconstruction: a joint adjustment (Ceres) of the survey's keyframe poses and its map
// lines, so that a localiser's errors (a pose tf gives that is centimetres and tenths of a degree off, wandering
// slowly) no longer smear the map.
//
// Keyframe poses are corrected in the plane of the floor only (x, y and yaw: what a 2D localiser gets wrong; height,
// roll and pitch come from the robot's fixed mount), each correction a rotation about the keyframe's own camera
// position and a translation, so that the localiser's x, y and yaw sigmas apply to it directly. Map lines have four
// degrees of freedom (two across the line for its position, two for its direction, relative to the start).
//
// Residuals per observation of a map line by a keyframe (KeyframeLine, in the camera's frame):
//  - the 2D segment's two end points against the map line's projection (point-to-line, px over rgb_sigma_px);
//  - the depth-based 3D line's two end points against the map line, along the line of sight within the
//    observation's interpretation plane (over its predicted error: depth noise grows as z^2), the component the 2D
//    residual leaves open;
//  - per keyframe a prior to the pose tf gave (localization_sigma_m, localization_sigma_deg), independent or, with
//    localization_correlation_s, a Gauss-Markov chain over the keyframes in time order. The priors are the only
//    absolute information, so the map's placement in the map frame is the localiser's errors averaged.
//  - odometry between consecutive keyframes that have it (their relative motion, wheel odometry's sigmas).
// Cauchy loss on the observations, then observations beyond outlier_sigmas are dropped and the problem solved again.
#ifndef INSITU_CALIBRATION_MAP_LINE_MAP_ADJUSTMENT_H
#define INSITU_CALIBRATION_MAP_LINE_MAP_ADJUSTMENT_H

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "insitu_calibration/error.h"
#include "insitu_calibration/lines/line3d_fitter.h"
#include "insitu_calibration/lines/line_map.h"
#include "insitu_calibration/map/surface_voxels.h"

namespace insitu_calibration
{
// One 3D line extracted in a keyframe, in the keyframe camera's optical frame.
struct KeyframeLine
{
  Line3d line;                                        // a, b in the camera frame (sensor at the origin)
  Eigen::Vector2d image_a = Eigen::Vector2d::Zero();  // the 2D segment's end points, undistorted normalised
  Eigen::Vector2d image_b = Eigen::Vector2d::Zero();  // coordinates (x / z, y / z)
};

// A 2D line of a keyframe's RGB image without a depth-based 3D line fit for the map, a candidate for a line on the
// floor (floor_lines.h): undistorted normalised coordinates of its end points (the ray is (x, y, 1)), and whether
// its own depth put it on the floor (FloorLineOptions::depth_confirmation).
struct FloorObservation
{
  Eigen::Vector2d image_a = Eigen::Vector2d::Zero();
  Eigen::Vector2d image_b = Eigen::Vector2d::Zero();
  bool depth_on_floor = false;
};

// A 2D line of a keyframe's RGB image above the horizon without a depth line fit for the map, a candidate for a
// line on the ceiling (ceiling_lines.h), with the height (map z, under the tf pose) and range of its depth.
struct CeilingObservation
{
  FloorObservation image;
  bool has_depth = false;
  double depth_height_m = 0.0;
  double range_m = 0.0;
};

// What the adjustment keeps of a keyframe (no images: memory grows with keyframes and lines only).
struct Keyframe
{
  double stamp = 0.0;
  Eigen::Isometry3d T_map_camera = Eigen::Isometry3d::Identity();  // as tf gave it
  double focal_px = 0.0;                                           // of the RGB image (for the 2D residuals in px)
  int image_width = 0;                                             // of the RGB image, px (its field of view)
  int image_height = 0;
  // The camera in the odometry frame (odom -> camera), when odometry is available: consecutive keyframes that both
  // have it are tied by their relative motion.
  bool has_odometry = false;
  Eigen::Isometry3d T_odom_camera = Eigen::Isometry3d::Identity();
  // The first keyframe of a recording after another (Survey::startRecording, calibrate_survey with several bags):
  // neither odometry nor the localiser's chain ties it to the keyframe before (another drive, perhaps another
  // odometry origin and another localisation run).
  bool starts_recording = false;
  std::vector<KeyframeLine> lines;
  std::vector<FloorObservation> floor;      // not adjusted: placed on the floor under the corrected pose
  std::vector<FloorObservation> rgb;        // every RGB segment without a depth line, when lines are triangulated
  DepthRangeGrid depth_grid;                // its depth's nearest and farthest per image cell, when triangulating
  std::vector<CeilingObservation> ceiling;  // when ceiling lines are enabled
  // Its depth samples in the camera frame (SurfaceVoxels::depthSamples, thinned), when the survey tests occlusion
  // and adjusts the map: the surfaces are inserted again under the corrected pose.
  std::vector<Eigen::Vector3f> surface;
};

// A keyframe's correction: T_map_camera(corrected) = C * T_map_camera(tf), C a rotation by yaw about the vertical
// through pivot (the tf camera position) followed by a translation (x, y).
struct PoseCorrection
{
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;  // rad
  Eigen::Isometry3d apply(const Eigen::Isometry3d& T_map_camera) const;
};

// A map line: a point on it and its unit direction.
struct AdjustedLine
{
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
};

// Which map line a keyframe's line observes.
struct LineObservation
{
  int keyframe = 0;
  int line = 0;  // index into the keyframe's lines
  int map_line = 0;
};

struct LineMapAdjustmentOptions
{
  double localization_sigma_m = 0.02;   // per keyframe, x and y of the pose tf gave
  double localization_sigma_deg = 0.5;  // yaw
  // The localiser's error as a stationary Gauss-Markov process with this correlation time (s, over the keyframes'
  // stamps): the priors then form a chain, each keyframe's correction tied to the previous one's (an AMCL-like
  // localiser wanders slowly: its errors at keyframes a fraction of a second apart are nearly the same, and one
  // independent prior per keyframe would pull whole stretches of the map the same wrong way). The chain gives the
  // survey's shape; the whole survey is then turned and shifted rigidly to where independent priors place it (the
  // localiser's average over the keyframes: the shifts' mean is zero). 0: independent priors.
  // Survey sets it from SurveyOptions::localization_correlation_s.
  double localization_correlation_s = 0.0;
  double rgb_sigma_px = 0.3;     // the Xtion RGB segments' end points across the line
  double depth_floor_m = 0.002;  // in quadrature with an observation's predicted depth error
  double loss_sigmas = 3.0;      // Cauchy scale, in sigmas
  double outlier_sigmas = 5.0;   // observations with a residual beyond are dropped (second solve)
  int max_iterations = 50;
  // Above this many keyframes the solver's linear steps are conjugate gradients on the keyframes' reduced system
  // (Ceres ITERATIVE_SCHUR, Schur-Jacobi preconditioner) instead of its sparse Cholesky factorisation (SPARSE_SCHUR),
  // whose cost grows with the cube of the keyframes: 0 = always the factorisation. The default keeps the
  // factorisation for surveys up to about 2 min (a 35-40 s survey has 80-120 keyframes).
  size_t iterative_above_keyframes = 300;
  // Odometry between consecutive keyframes: translation sigma sigma_m + per_m times the distance, rotation sigma
  // sigma_deg + per_deg times the turn. 0 odometry_sigma_m: odometry not used.
  // Defaults: good wheel odometry over the 0.1 m / 5 degree steps between keyframes (the simulator's odometry is
  // exact unless --odom-drift, whose random walk needs far larger sigmas).
  double odometry_sigma_m = 0.0005;
  double odometry_sigma_per_m = 0.01;
  double odometry_sigma_deg = 0.02;
  double odometry_sigma_per_deg = 0.01;
  // With localization_correlation_s above 0 the standard deviations are the chain's, before the rigid placement:
  // they hold for the survey's shape, not for its placement in the map frame (Survey::mapPlacement gives that).
  bool covariance = false;  // also the keyframe poses' and map lines' standard deviations (Ceres' covariance)
};

struct LineMapAdjustmentResult
{
  std::vector<PoseCorrection> corrections;  // per keyframe
  std::vector<AdjustedLine> lines;          // per map line
  std::vector<bool> inlier;                 // per observation
  size_t dropped = 0;                       // observations dropped as outliers
  // With options.covariance (empty when it failed): per keyframe the standard deviations of x, y (m) and yaw (rad)
  // of its corrected pose, per map line the standard deviation of its position across it (m, the larger axis at its
  // point) and of its direction (rad, the larger axis).
  std::vector<Eigen::Vector3d> pose_sigmas;
  std::vector<Eigen::Vector2d> line_sigmas;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  double cpu_ms = 0.0;
  bool iterative = false;  // the linear steps were conjugate gradients (options.iterative_above_keyframes)
};

// Adjusts keyframe poses and map lines jointly, from the given starts (corrections: empty or one per keyframe).
// Errors: kInvalidInput for observations that point outside keyframes / lines or sigmas that are not positive,
// kNotEnoughData without observations.
Expected<LineMapAdjustmentResult> adjustLineMap(const std::vector<Keyframe>& keyframes,
                                                const std::vector<AdjustedLine>& lines,
                                                const std::vector<LineObservation>& observations,
                                                const std::vector<PoseCorrection>& corrections,
                                                const LineMapAdjustmentOptions& options);

// A keyframe's line in the map frame under a corrected pose (a, b and sensor moved).
Line3d lineInMap(const Keyframe& keyframe, const KeyframeLine& line, const PoseCorrection& correction);

// The line map rebuilt from every keyframe's lines under the corrected poses (corrections: one per keyframe).
LineMap rebuildLineMap(const std::vector<Keyframe>& keyframes, const std::vector<PoseCorrection>& corrections,
                       const LineMapOptions& options);

// The surfaces the keyframes' depth samples (Keyframe::surface) measured, under the corrected poses (corrections: one
// per keyframe): where a localiser's error smears them at tf's poses, a wall grows thick enough to hide the lines on it
// from a camera that sees it at a grazing angle.
SurfaceVoxels rebuildSurfaces(const std::vector<Keyframe>& keyframes, const std::vector<PoseCorrection>& corrections,
                              const SurfaceVoxelOptions& options);

// Each keyframe line's map line under the corrected poses: the closest of the compatible ones (direction within
// max_angle_deg, end points within the map's lateral and depth limits of it, extents overlapping or at most
// max_gap_m apart), none when no map line is compatible.
std::vector<LineObservation> associateObservations(const std::vector<Keyframe>& keyframes,
                                                   const std::vector<PoseCorrection>& corrections,
                                                   const std::vector<MapLine>& lines, const LineMapOptions& options);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MAP_LINE_MAP_ADJUSTMENT_H
