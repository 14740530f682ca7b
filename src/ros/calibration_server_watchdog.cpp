// The calibration node's moved-camera watchdog: ~verify on demand and a check of every calibrated camera every
// verify_period_s. The measurement is the core's (FixedCamera::verify, survey/camera_verification.h); this file
// reads parameters, takes snapshots and reports (log, ~status, /diagnostics).
#include <optional>

#include "insitu_calibration/ros/calibration_server.h"

namespace insitu_calibration
{
namespace
{
bool refuseVerify(Verify::Response& response, const std::string& reason)
{
  response.success = false;
  response.moved = "unknown";
  response.message = reason;
  return true;
}
}  // namespace

void CalibrationServer::setupWatchdog()
{
  // On the work queue: a check waits for a calibration in progress instead of judging the calibration it replaces.
  verify_server_ = work_nh_.advertiseService("verify", &CalibrationServer::verifyService, this);
  // Created even when off (period 0): dynamic_reconfigure may start it (applyThresholds).
  const double period_s = thresholds().verify_period_s;
  verify_timer_ = work_nh_.createWallTimer(
      ros::WallDuration(period_s > 0.0 ? period_s : 60.0),
      [this](const ros::WallTimerEvent&) { verifyCalibratedCameras(); }, false, period_s > 0.0);
}

FieldThresholds CalibrationServer::thresholds() const
{
  std::lock_guard<std::mutex> lock(mutex_);
  return thresholds_;
}

Expected<CameraMotion> CalibrationServer::verifyCamera(const std::string& name)
{
  std::optional<FixedCamera> camera;
  std::vector<Segment3d> map;
  std::vector<double> sigmas;
  CameraVerificationOptions options;
  {
    std::lock_guard<std::mutex> lock(mutex_);  // a snapshot (the copy shares its images); the work without the lock
    camera.emplace(survey_->camera(name));
    map = survey_->latestMapSegments();
    sigmas = survey_->latestMapLineSigmas();
    options = thresholds_.watchdog;
  }
  if (camera->calibration() && map.empty())
    return Error(ErrorCode::kNotEnoughData, "cannot verify '" + name +
                                                "': the 3D line map is empty (it is not saved: survey the camera's "
                                                "view again after a restart)");
  auto motion = camera->verify(map, options, sigmas);
  if (!motion)
    return motion;
  {
    // Kept only while it still describes the camera's calibration (an action may have replaced it meanwhile).
    std::lock_guard<std::mutex> lock(mutex_);
    const auto& now = survey_->camera(name).calibration();
    std::lock_guard<std::mutex> motion_lock(motion_mutex_);
    if (now && camera->calibration() && now->camera.pose().rotation == camera->calibration()->camera.pose().rotation &&
        now->camera.pose().translation == camera->calibration()->camera.pose().translation)
      last_motion_[name] = *motion;
  }
  if (motion->verdict == CameraMotionVerdict::kMoved)
    ROS_WARN_STREAM("calibration_node: " << name << ": " << motion->message);
  else
    ROS_INFO_STREAM("calibration_node: " << name << ": " << motion->message);
  return motion;
}

void CalibrationServer::verifyCalibratedCameras()
{
  for (const auto& [name, ros_camera] : cameras_)
  {
    bool checkable = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      checkable = survey_->camera(name).calibration() && survey_->camera(name).imageCount() > 0;
    }
    if (!checkable)
      continue;
    if (const auto motion = verifyCamera(name); !motion)
      ROS_WARN_STREAM_THROTTLE(300.0, "calibration_node: " << name << ": " << motion.error().message());
  }
}

bool CalibrationServer::verifyService(Verify::Request& request, Verify::Response& response)
{
  std::string error;
  if (request.camera.empty() || selectCameras(request.camera, &error).empty())
    return refuseVerify(response, request.camera.empty() ? "name the camera to verify" : error);
  const auto motion = verifyCamera(request.camera);
  if (!motion)
    return refuseVerify(response, motion.error().message());
  response.success = true;
  response.moved = motion->verdict == CameraMotionVerdict::kMoved     ? "yes"
                   : motion->verdict == CameraMotionVerdict::kUnmoved ? "no"
                                                                      : "unknown";
  response.displacement_px = motion->displacement_px;
  response.displacement_sigma_px = motion->displacement_sigma_px;
  response.rotation_deg = motion->rotation_deg;
  response.rotation_sigma_deg = motion->rotation_sigma_deg;
  response.translation_m = motion->translation_m;
  response.translation_sigma_m = motion->translation_sigma_m;
  response.matched_lines = static_cast<uint32_t>(motion->matched_lines);
  response.message = motion->message;
  return true;
}

std::optional<CameraMotion> CalibrationServer::lastMotion(const std::string& name)
{
  std::lock_guard<std::mutex> lock(motion_mutex_);
  const auto it = last_motion_.find(name);
  return it == last_motion_.end() ? std::nullopt : std::optional<CameraMotion>(it->second);
}

void CalibrationServer::forgetMotion(const std::string& name)
{
  std::lock_guard<std::mutex> lock(motion_mutex_);
  if (name.empty())
    last_motion_.clear();
  else
    last_motion_.erase(name);
}

}  // namespace insitu_calibration
