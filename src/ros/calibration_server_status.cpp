// The calibration node's status reporting: /diagnostics (diagnostic_updater) per camera and for the survey, the
// latched ~survey_status topic, and the per-camera status that ~status shares with it. Reads the survey under
// mutex_ only to take a snapshot; the work (median images and their lines) runs without it.
#include <algorithm>

#include <diagnostic_msgs/DiagnosticStatus.h>

#include "insitu_calibration/ros/calibration_server.h"
#include "insitu_calibration/survey/uncertainty_budget.h"

namespace insitu_calibration
{
void CalibrationServer::setupStatusReporting()
{
  // Its parameters were read (and checked) by loadParameters.
  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, private_nh_);
  diagnostics_->setHardwareID("insitu_calibration");
  diagnostics_->add("survey", [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { surveyDiagnostics(stat); });
  for (const auto& [name, camera] : cameras_)
  {
    const std::string camera_name = name;
    diagnostics_->add("camera " + name, [this, camera_name](diagnostic_updater::DiagnosticStatusWrapper& stat) {
      cameraDiagnostics(camera_name, stat);
    });
  }
  // On the reports' thread: /diagnostics and the status topic never wait behind images or a calibration, nor
  // ~status behind them. A wall timer and force_update: Updater::update() paces itself on ROS time, which stops
  // with a bag's /clock.
  diagnostics_timer_ = report_nh_.createWallTimer(
      ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { diagnostics_->force_update(); });
  survey_status_publisher_ = private_nh_.advertise<SurveyStatus>("survey_status", 1, true);
  if (status_period_s_ > 0.0)
    survey_status_timer_ = report_nh_.createWallTimer(ros::WallDuration(status_period_s_),
                                                       [this](const ros::WallTimerEvent&) { publishSurveyStatus(); });
}

std::vector<CameraStatus> CalibrationServer::cameraStatuses(const std::vector<std::string>& names, std::string* summary,
                                                            SurveyStatus* survey)
{
  // A snapshot under the lock (FixedCamera copies share their images), the work without it.
  std::vector<FixedCamera> cameras;
  std::vector<Segment3d> map;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    map = survey_->latestMapSegments();
    const SurveyStats& stats = survey_->stats();
    *summary = std::to_string(stats.frames) + " RGB-D frames received, " + std::to_string(stats.keyframes) +
               " keyframes used, " + std::to_string(survey_->latestLineMap().size()) + " map lines (" +
               std::to_string(map.size()) + " seen at least " + std::to_string(survey_->options().min_map_support) +
               " times)";
    if (survey)
    {
      survey->rgbd_frames = static_cast<uint32_t>(stats.frames);
      survey->keyframes = static_cast<uint32_t>(stats.keyframes);
      survey->map_lines = static_cast<uint32_t>(survey_->latestLineMap().size());
      survey->map_lines_used = static_cast<uint32_t>(map.size());
    }
    for (const auto& name : names)
      cameras.push_back(survey_->camera(name));
  }
  std::vector<CameraStatus> out;
  for (const FixedCamera& camera : cameras)
  {
    const FixedCameraStatus s = camera.status(map);
    CameraStatus msg;
    msg.camera_name = camera.config().name;
    msg.has_image = s.has_image;
    msg.images = static_cast<uint32_t>(s.images);
    msg.image_lines = static_cast<uint32_t>(s.image_lines);
    msg.map_lines = static_cast<uint32_t>(s.map_lines);
    msg.map_lines_visible = static_cast<uint32_t>(s.map_lines_visible);
    msg.matched_lines = static_cast<uint32_t>(s.matched_lines);
    msg.coverage_percent = s.coverage_percent;
    msg.calibrated = s.calibrated;
    msg.ready = s.ready;
    msg.message = s.message;
    if (const auto motion = lastMotion(msg.camera_name))
    {
      msg.motion = toString(motion->verdict);
      msg.motion_displacement_px = motion->displacement_px;
      msg.motion_rotation_deg = motion->rotation_deg;
      msg.motion_message = motion->message;
    }
    out.push_back(msg);
  }
  return out;
}

void CalibrationServer::publishSurveyStatus()
{
  std::vector<std::string> names;
  for (const auto& [name, camera] : cameras_)
    names.push_back(name);
  SurveyStatus msg;
  msg.cameras = cameraStatuses(names, &msg.message, &msg);
  msg.header.stamp = ros::Time::now();
  survey_status_publisher_.publish(msg);
}

void CalibrationServer::surveyDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat)
{
  size_t frames = 0, keyframes = 0, map_lines = 0, calibrated = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    frames = survey_->stats().frames;
    keyframes = survey_->stats().keyframes;
    map_lines = survey_->latestLineMap().size();
    for (const auto& [name, camera] : cameras_)
      calibrated += survey_->camera(name).calibration() ? 1 : 0;
  }
  stat.add("RGB-D frames", frames);
  stat.add("keyframes", keyframes);
  stat.add("map lines", map_lines);
  stat.add("cameras calibrated", std::to_string(calibrated) + " of " + std::to_string(cameras_.size()));
  stat.add("depth registration", describeDepthRegistration());
  if (calibrated == cameras_.size())
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "every camera calibrated");
  else if (frames == 0)
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "waiting for the survey (no RGB-D frame yet)");
  else
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::OK,
                  "surveying: %zu keyframes, %zu map lines, %zu of %zu cameras "
                  "calibrated",
                  keyframes, map_lines, calibrated, cameras_.size());
}

void CalibrationServer::cameraDiagnostics(const std::string& name, diagnostic_updater::DiagnosticStatusWrapper& stat)
{
  std::optional<CalibrationFile> calibration;
  FieldThresholds limits;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    calibration = survey_->camera(name).calibration();
    limits = thresholds_;
  }
  size_t images = 0;
  std::optional<double> age_s;
  {
    std::lock_guard<std::mutex> lock(info_mutex_);
    images = image_count_[name];
    if (const auto it = last_image_.find(name); it != last_image_.end())
      age_s = (ros::WallTime::now() - it->second).toSec();
  }
  const std::string& topic = survey_->camera(name).config().image_topic;  // the configuration is fixed
  stat.add("image topic", topic);
  stat.add("images received", images);
  stat.add("last image age (s)", age_s ? *age_s : -1.0);
  stat.add("calibrated", calibration.has_value());
  double sigma_position = 0.0, sigma_rotation = 0.0;
  if (calibration && calibration->quality)
  {
    const auto& extra = calibration->quality->extra;
    sigma_position = extra.count("sigma_position_m") ? extra.at("sigma_position_m") : 0.0;
    sigma_rotation = extra.count("sigma_rotation_deg") ? extra.at("sigma_rotation_deg") : 0.0;
    stat.add("rms (px)", calibration->quality->rms_px);
    stat.add("sigma position (m)", sigma_position);
    stat.add("sigma rotation (deg)", sigma_rotation);
    if (const auto budget = uncertaintyBudgetOf(extra))
      stat.add("sigma parts (position / rotation)", describeBudget(*budget));
  }
  const std::optional<CameraMotion> motion = calibration ? lastMotion(name) : std::nullopt;
  if (motion)
  {
    stat.add("moved", toString(motion->verdict));
    stat.add("displacement since calibration (px)", motion->displacement_px);
    stat.add("rotation since calibration (deg)", motion->rotation_deg);
    stat.add("last check", motion->message);
  }
  using diagnostic_msgs::DiagnosticStatus;
  if (!age_s)
    stat.summaryf(DiagnosticStatus::ERROR, "no images on %s", topic.c_str());
  else if (*age_s > limits.stale_image_s)
    stat.summaryf(DiagnosticStatus::WARN, "stale images: the last one arrived %.0f s ago", *age_s);
  else if (!calibration)
    stat.summary(DiagnosticStatus::WARN, "not calibrated");
  else if (motion && motion->verdict == CameraMotionVerdict::kMoved)
    stat.summaryf(DiagnosticStatus::WARN, "camera moved by %.1f px / %.2f deg since calibration: recalibrate",
                  motion->displacement_px, motion->rotation_deg);
  else if (sigma_position > limits.max_sigma_position_m || sigma_rotation > limits.max_sigma_rotation_deg)
    stat.summary(DiagnosticStatus::WARN, describeTooUncertain(calibration->quality->extra, limits.max_sigma_position_m,
                                                              limits.max_sigma_rotation_deg));
  else
    stat.summary(DiagnosticStatus::OK, "calibrated");
}

}  // namespace insitu_calibration
