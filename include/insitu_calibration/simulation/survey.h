// A survey of a World: what the robot's Xtion and the fixed cameras record, when, and the ground truth. ROS-free;
// the ROS layer (ros/survey_bag_writer.h) turns it into a bag.
//
// Timeline (nanoseconds from the start, integers so that stamps line up exactly):
//   /tf_static at 0; /tf (map -> odom -> base_link) every tf period, a divisor of the image period (>= 20 Hz by
//   default), so that every RGB-D stamp has a tf sample; RGB-D frames at the survey rate, the first at 0; each fixed
//   camera at its own rate from its phase. Everything up to the duration.
// Determinism: every noise draw comes from a stream keyed by (seed, what, camera, frame), so the same seed gives the
// same messages whatever the order of the calls.
#ifndef INSITU_CALIBRATION_SIMULATION_SURVEY_H
#define INSITU_CALIBRATION_SIMULATION_SURVEY_H

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "insitu_calibration/error.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/trajectory.h"
#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace simulation
{
struct SimulationOptions
{
  double duration_s = 40.0;
  double rate_hz = 5.0;  // RGB-D frames
  uint64_t seed = 0;
  double tf_min_rate_hz = 20.0;
  std::optional<double> fixed_rate_hz;  // overrides every fixed camera's rate
  bool depth_noise = true;              // false: exact depth (rounded to mm), no-return rules kept
  bool image_noise = true;              // false: fixed cameras (and Xtion RGB) without sensor noise
  bool odom_drift = false;              // odom -> base_link drifts (random walk), map -> odom compensates
  double odom_drift_xy = 0.02;          // m per sqrt(s)
  double odom_drift_yaw_deg = 0.5;      // deg per sqrt(s)
  // The localiser's error (AMCL-like): the map -> base_link of /tf is the true pose moved by a smooth random error
  // in x, y and yaw (each a stationary Gauss-Markov process of this standard deviation and correlation time; the
  // error lands on map -> odom, odom -> base_link stays the odometry). 0: exact localisation.
  double localization_sigma_m = 0.0;
  double localization_sigma_deg = 0.0;
  double localization_tau_s = 5.0;
  int64_t start_time_ns = 1700000000LL * 1000000000LL;  // stamp of the start (fixed: same seed, same bag)
};

enum class SurveyEventKind
{
  kStaticTf,
  kTf,
  kXtion,
  kFixed
};

struct SurveyEvent
{
  int64_t stamp_ns = 0;  // from the start
  SurveyEventKind kind = SurveyEventKind::kTf;
  int camera = -1;  // kFixed: index into World::fixed_cameras
  int index = 0;    // frame number of its stream
};

struct XtionFrame
{
  int64_t stamp_ns = 0;
  cv::Mat rgb;       // CV_8UC3, RGB
  cv::Mat depth_mm;  // CV_16UC1, registered to the RGB camera, 0 = no return
  Eigen::Isometry3d map_from_optical = Eigen::Isometry3d::Identity();  // camera_rgb_optical_frame in map (truth)
};

struct FixedFrame
{
  int64_t stamp_ns = 0;
  int camera = 0;
  cv::Mat image;  // CV_8UC3, RGB
};

struct SurveyTimings
{
  double xtion_render_s = 0.0;
  double xtion_sensor_s = 0.0;  // depth model and RGB noise
  double fixed_render_s = 0.0;  // clean images, once per camera
  double fixed_noise_s = 0.0;
  int xtion_frames = 0;
  int fixed_frames = 0;
};

class SurveySimulator
{
public:
  static Expected<SurveySimulator> create(World world, const SimulationOptions& options);

  const World& world() const { return *world_; }
  const SimulationOptions& options() const { return options_; }
  const Renderer& renderer() const { return *renderer_; }
  const RouteTrajectory& trajectory() const { return trajectory_; }

  // Every message to record, sorted by stamp (static tf first).
  const std::vector<SurveyEvent>& events() const { return events_; }
  int64_t durationNs() const { return duration_ns_; }
  double tfRateHz() const { return 1e9 / static_cast<double>(tf_period_ns_); }
  double fixedRateHz(int camera) const;
  size_t xtionFrameCount() const { return xtion_stamps_.size(); }

  std::vector<NamedTransform> staticTransforms() const;
  // map -> odom and odom -> base_link at a stamp (their product is the true map -> base_link).
  std::vector<NamedTransform> dynamicTransforms(int64_t stamp_ns) const;
  // The true map -> base_link (the truth; /tf carries localizedMapFromBase).
  Eigen::Isometry3d mapFromBase(int64_t stamp_ns) const;
  // The localiser's error at a stamp (x, y in the map frame, yaw; zero without --localization-error) and the
  // map -> base_link it believes: the true pose moved by it.
  Pose2d localizationError(int64_t stamp_ns) const;
  Eigen::Isometry3d localizedMapFromBase(int64_t stamp_ns) const;
  const std::vector<int64_t>& xtionStamps() const { return xtion_stamps_; }

  ViewCamera xtionCamera(int64_t stamp_ns) const;
  ViewCamera fixedCamera(int camera) const;

  XtionFrame xtionFrame(int index) const;
  // The clean image (rendered, then the camera's blur, vignetting and gains) is made once per camera; each frame gets
  // fresh sensor noise, then its JPEG compression.
  FixedFrame fixedFrame(int camera, int index) const;
  const cv::Mat& fixedCleanImage(int camera) const;

  // The true calibration of a fixed camera, in calibrate_lines' output format.
  CalibrationFile groundTruth(int camera) const;

  const SurveyTimings& timings() const { return timings_; }

private:
  SurveySimulator(World world, const SimulationOptions& options);

  std::unique_ptr<World> world_;  // stable address: the renderer refers to it
  std::unique_ptr<Renderer> renderer_;
  SimulationOptions options_;
  RouteTrajectory trajectory_;
  int64_t duration_ns_ = 0;
  int64_t tf_period_ns_ = 0;
  std::vector<int64_t> xtion_stamps_;
  std::vector<int64_t> tf_stamps_;
  std::vector<std::vector<int64_t>> fixed_stamps_;
  std::vector<SurveyEvent> events_;
  std::vector<Pose2d> drift_;         // per tf stamp, when odom drift is on
  std::vector<Pose2d> localization_;  // per tf stamp, when the localiser errs
  mutable std::vector<cv::Mat> fixed_clean_;
  mutable SurveyTimings timings_;
};

// Renders every frame of the survey and discards it (the benchmark: see survey.timings() afterwards).
void renderWholeSurvey(const SurveySimulator& survey);

// Where the ground truth of a bag goes: "dir/survey.bag" -> "dir/survey_truth".
std::string truthDirectoryFor(const std::string& bag_path);

// Writes into directory: <camera>.yaml for every fixed camera (saveCalibrationFile), edges.yaml (the true 3D
// edges), survey.yaml (world, seed, duration, rates, the Xtion's intrinsics, topics and frames) and
// localization.yaml (per RGB-D frame its stamp and the localiser's error x, y in m and yaw in degrees).
Status writeGroundTruth(const SurveySimulator& survey, const std::string& directory,
                        const std::vector<std::string>& topics);

// The localiser's error at one RGB-D frame, as localization.yaml holds it.
struct LocalizationSample
{
  double stamp = 0.0;  // seconds since the epoch
  Pose2d error;        // x, y in m, yaw in rad
};
// Reads <truth>/localization.yaml. Errors: unreadable or malformed file.
Expected<std::vector<LocalizationSample>> loadLocalizationErrors(const std::string& path);

// The best any method can place a survey: the localiser's errors at the keyframes (stamps, tf positions as pivots)
// averaged, applied to a point: how far it moves (m) and the mean yaw (rad). No method can place the map better
// than this mean error (the localiser is the only absolute reference).
struct PlacementLimit
{
  double position_m = 0.0;
  double rotation_rad = 0.0;
};
PlacementLimit placementLimit(const std::vector<LocalizationSample>& errors, const std::vector<double>& stamps,
                              const std::vector<Eigen::Vector3d>& pivots, const Eigen::Vector3d& point);
// The same from each keyframe's own localiser error (a survey in several recordings: each its own errors).
PlacementLimit placementLimit(const std::vector<Pose2d>& keyframe_errors, const std::vector<Eigen::Vector3d>& pivots,
                              const Eigen::Vector3d& point);

// The sample nearest in time to stamp (errors sorted by stamp, not empty).
const LocalizationSample& nearestLocalizationSample(const std::vector<LocalizationSample>& errors, double stamp);

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_SURVEY_H
