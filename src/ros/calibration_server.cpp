#include "insitu_calibration/ros/calibration_server.h"

#include <cstdlib>
#include <filesystem>
#include <optional>

#include <boost/bind/bind.hpp>
#include <boost/make_shared.hpp>
#include <cv_bridge/cv_bridge.h>
#include <opencv2/imgcodecs.hpp>
#include <tf2_eigen/tf2_eigen.h>
#include <visualization_msgs/MarkerArray.h>
#include <yaml-cpp/yaml.h>

#include "insitu_calibration/ros/conversions.h"
#include "insitu_calibration/ros/parameter_reader.h"
#include "insitu_calibration/survey/calibration_report.h"
#include "insitu_calibration/survey/survey_parameters.h"
#include "insitu_calibration/survey/uncertainty_budget.h"
#include "insitu_calibration/survey/camera_config.h"
#include "insitu_calibration/survey/overlay.h"
#include "insitu_calibration/io/calibration_store.h"

namespace insitu_calibration
{
namespace
{
// A service request that names no known camera: answered (true) with success false and the reason.
template <typename Response>
bool refuseRequest(Response& response, const std::string& reason)
{
  response.success = false;
  response.message = reason;
  return true;
}

// The parameter server's XmlRpc value as YAML text, for the core's configuration parser.
void emitYaml(XmlRpc::XmlRpcValue& value, YAML::Emitter* out)
{
  switch (value.getType())
  {
    case XmlRpc::XmlRpcValue::TypeArray:
      *out << YAML::BeginSeq;
      for (int i = 0; i < value.size(); ++i)
        emitYaml(value[i], out);
      *out << YAML::EndSeq;
      break;
    case XmlRpc::XmlRpcValue::TypeStruct:
      *out << YAML::BeginMap;
      for (auto& member : value)
      {
        *out << YAML::Key << member.first << YAML::Value;
        emitYaml(member.second, out);
      }
      *out << YAML::EndMap;
      break;
    case XmlRpc::XmlRpcValue::TypeInt:
      *out << static_cast<int>(value);
      break;
    case XmlRpc::XmlRpcValue::TypeDouble:
      *out << static_cast<double>(value);
      break;
    case XmlRpc::XmlRpcValue::TypeBoolean:
      *out << static_cast<bool>(value);
      break;
    case XmlRpc::XmlRpcValue::TypeString:
      *out << YAML::DoubleQuoted << static_cast<std::string>(value);
      break;
    default:
      *out << YAML::Null;
  }
}

std::string defaultOutputDirectory()
{
  if (const char* ros_home = std::getenv("ROS_HOME"))
    return std::string(ros_home) + "/insitu_calibration";
  const char* home = std::getenv("HOME");
  return std::string(home ? home : ".") + "/.ros/insitu_calibration";
}

std::string expandHome(const std::string& path)
{
  if (!path.empty() && path[0] == '~')
  {
    const char* home = std::getenv("HOME");
    return std::string(home ? home : "") + path.substr(1);
  }
  return path;
}

// The namespace of a topic: "/fixed/cam/image_raw" -> "/fixed/cam".
std::string topicNamespace(const std::string& topic)
{
  const auto slash = topic.rfind('/');
  return slash == std::string::npos ? std::string() : topic.substr(0, slash);
}

std::string stringMember(XmlRpc::XmlRpcValue& entry, const char* key, const std::string& fallback)
{
  if (entry.getType() == XmlRpc::XmlRpcValue::TypeStruct && entry.hasMember(key) &&
      entry[key].getType() == XmlRpc::XmlRpcValue::TypeString)
    return static_cast<std::string>(entry[key]);
  return fallback;
}

bool boolMember(XmlRpc::XmlRpcValue& entry, const char* key, bool fallback)
{
  if (entry.getType() == XmlRpc::XmlRpcValue::TypeStruct && entry.hasMember(key) &&
      entry[key].getType() == XmlRpc::XmlRpcValue::TypeBoolean)
    return static_cast<bool>(entry[key]);
  return fallback;
}

visualization_msgs::Marker lineList(const std::string& frame, const std::string& ns, int id,
                                    const std::vector<Segment3d>& segments, float r, float g, float b, double width)
{
  visualization_msgs::Marker m;
  m.header.frame_id = frame;
  m.ns = ns;
  m.id = id;
  m.type = visualization_msgs::Marker::LINE_LIST;
  m.action = segments.empty() ? visualization_msgs::Marker::DELETE : visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = width;
  m.color.r = r;
  m.color.g = g;
  m.color.b = b;
  m.color.a = 1.0;
  for (const auto& s : segments)
  {
    m.points.push_back(toPointMsg(s.a));
    m.points.push_back(toPointMsg(s.b));
  }
  return m;
}

// How far the camera moved from the calibration a new one replaces (the operator asked for a new one: why?), into
// the result; returns it in words ("; moved by ..."), empty without a previous calibration.
std::string notePreviousCalibration(const std::optional<CalibrationFile>& previous, const CalibrationFile& now,
                                    const std::vector<Segment3d>& map, insitu_calibration::CalibrationResult* msg)
{
  if (!previous)
    return "";
  const PoseDifference change = calibrationChange(*previous, now, map);
  msg->had_previous = true;
  msg->moved_displacement_px = change.displacement_px;
  msg->moved_rotation_deg = change.rotation_deg;
  msg->moved_translation_m = change.translation_m;
  const std::string note = "; " + describeChange(change);
  msg->message += note;
  return note;
}

// The calibration report beside the YAML (calibration_report.h), for people: a failure loses no calibration and is
// only logged.
void writeReport(const std::string& directory, const FixedCameraConfig& camera, const FixedCameraResult& result,
                 const cv::Mat& image, const std::vector<Segment3d>& map, size_t keyframes)
{
  const auto files = writeCalibrationReport(
      directory, fixedCameraReport(camera, result, image, map, ReportSurveySummary{keyframes, map.size()}));
  if (!files)
    ROS_WARN_STREAM("calibration_node: " << camera.name << ": " << files.error().message());
}
}  // namespace

CalibrationServer::CalibrationServer(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      it_(nh),
      tf_listener_(tf_buffer_),
      service_nh_(private_nh),
      work_nh_(private_nh),
      report_nh_(private_nh)
{
  service_nh_.setCallbackQueue(&service_queue_);
  work_nh_.setCallbackQueue(&work_queue_);
  report_nh_.setCallbackQueue(&report_queue_);
  if (!loadParameters())
  {
    ros::shutdown();
    return;
  }

  // The Xtion, with openni2_launch's names (remap them to another camera).
  rgb_subscriber_.subscribe(nh_, "camera/rgb/image_raw", 5);
  depth_subscriber_.subscribe(nh_, "camera/depth_registered/image_raw", 5);
  info_subscriber_.subscribe(nh_, "camera/rgb/camera_info", 5);
  synchronizer_ = std::make_unique<message_filters::Synchronizer<SyncPolicy>>(SyncPolicy(10), rgb_subscriber_,
                                                                              depth_subscriber_, info_subscriber_);
  synchronizer_->registerCallback(boost::bind(&CalibrationServer::rgbdCallback, this, boost::placeholders::_1,
                                              boost::placeholders::_2, boost::placeholders::_3));

  for (auto& [name, camera] : cameras_)
  {
    const std::string camera_name = name;
    camera.subscriber = it_.subscribe(
        survey_->camera(name).config().image_topic, 2,
        [this, camera_name](const sensor_msgs::ImageConstPtr& image) { fixedImageCallback(camera_name, image); });
    camera.overlay_publisher = private_nh_.advertise<sensor_msgs::Image>(name + "/overlay", 1, true);
    camera.survey_hint_publisher = private_nh_.advertise<sensor_msgs::Image>(name + "/survey_hint", 1, true);
    if (camera.camera_info_topic.empty())
      continue;
    if (camera.relay_image)
      camera.calibrated_publisher = it_.advertiseCamera(topicNamespace(camera.camera_info_topic) + "/image_raw", 2);
    else
      camera.camera_info_publisher = nh_.advertise<sensor_msgs::CameraInfo>(camera.camera_info_topic, 2);
  }
  marker_publisher_ = private_nh_.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  calibrate_server_ = work_nh_.advertiseService("calibrate", &CalibrationServer::calibrateService, this);
  status_server_ = service_nh_.advertiseService("status", &CalibrationServer::statusService, this);
  reset_server_ = service_nh_.advertiseService("reset", &CalibrationServer::resetService, this);
  save_server_ = service_nh_.advertiseService("save", &CalibrationServer::saveService, this);
  // The action (topics ~calibrate/goal, feedback, result, cancel; its goals run on its own thread).
  calibrate_action_ = std::make_unique<actionlib::SimpleActionServer<CalibrateAction>>(
      service_nh_, "calibrate", [this](const CalibrateGoalConstPtr& goal) { executeCalibrateAction(goal); }, false);
  calibrate_action_->start();
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
  work_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &work_queue_);
  report_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &report_queue_);
  setupStatusReporting();
  setupWatchdog();
  setupReconfigure();
  marker_timer_ = nh_.createWallTimer(ros::WallDuration(2.0), [this](const ros::WallTimerEvent&) {
    std::lock_guard<std::mutex> lock(mutex_);
    publishMarkers();
  });

  if (map_adjustment_period_s_ > 0.0)
    adjustment_timer_ = work_nh_.createWallTimer(ros::WallDuration(map_adjustment_period_s_),
                                                 [this](const ros::WallTimerEvent&) { refreshMapAdjustment(); });

  loadSavedCalibrations();
  // Only now: a service call must not see the node before its saved calibrations are loaded.
  service_spinner_->start();
  work_spinner_->start();
  report_spinner_->start();
  ROS_INFO_STREAM("calibration_node: " << cameras_.size() << " fixed camera(s), world frame '" << world_frame_
                                       << "', calibrations in " << output_directory_
                                       << ". Call ~calibrate once the robot has surveyed the cameras' views.");
}

CalibrationServer::~CalibrationServer()
{
  // No callback may run while the members below go: the action's thread and the spinners stop first.
  if (calibrate_action_)
    calibrate_action_->shutdown();
  if (service_spinner_)
    service_spinner_->stop();
  if (work_spinner_)
    work_spinner_->stop();
  if (report_spinner_)
    report_spinner_->stop();
  calibrate_action_.reset();
}

// Every numeric parameter is checked (type, finiteness, range) before use: a bad one is FATAL (README's
// parameter list gives the ranges).
SurveyOptions CalibrationServer::readParameters(ParameterReader& read)
{
  using Range = ParameterRange;
  world_frame_ = read.text("world_frame", "map", false);
  output_directory_ = expandHome(read.text("output_directory", defaultOutputDirectory(), false));
  odom_frame_ = read.text("odom_frame", "odom", true);  // empty: no odometry between keyframes
  tf_timeout_s_ = read.number("tf_timeout", 0.2, Range::closed(0.0, 60.0, "s"));
  status_period_s_ = read.number("status_period", 5.0, Range::closed(0.0, 86400.0, "s"));  // 0: off
  // 0: the map is adjusted only before a calibration.
  map_adjustment_period_s_ =
      read.number("map_adjustment_period", map_adjustment_period_s_, Range::closed(0.0, 86400.0, "s"));
  // The survey's parameters, shared with calibrate_survey, and the thresholds tuned in the field (also through
  // dynamic_reconfigure, from one table): the defaults are the option structs' own.
  const SurveyOptions options = readSurveyParameters(read, SurveyOptions{}, &thresholds_);
  write_report_ = read.flag("write_report", write_report_);
  registration_given_ = depthRegistrationGiven(read);
  registration_rgbd_ = options.rgbd;
  if (read.flag("depth_registration/estimate", !registration_given_))
    registration_estimator_ = std::make_unique<DepthRegistrationEstimator>();
  return options;
}

bool CalibrationServer::loadParameters()
{
  ParameterReader read(private_nh_);
  const SurveyOptions options = readParameters(read);
  for (const std::string& error : read.errors())
    ROS_FATAL_STREAM("calibration_node: " << error);
  if (!read.ok())
    return false;

  XmlRpc::XmlRpcValue cameras;
  if (!private_nh_.getParam("cameras", cameras))
  {
    ROS_FATAL(
        "calibration_node: the private parameter ~cameras (a list of fixed cameras) is missing; load a "
        "configuration such as config/cameras.yaml (survey.launch's cameras argument)");
    return false;
  }
  YAML::Emitter yaml;
  yaml.SetDoublePrecision(15);
  emitYaml(cameras, &yaml);
  const auto configs = parseCameraConfig(yaml.c_str());
  if (!configs)
  {
    ROS_FATAL_STREAM("calibration_node: ~" << configs.error().message());
    return false;
  }
  std::vector<FixedCameraConfig> fixed;
  for (const CameraConfigEntry& entry : *configs)
  {
    Camera camera;
    camera.link_frame = entry.camera.name + "_link";
    camera.optical_frame = entry.camera.name + "_optical_frame";
    camera.info_publisher = nh_.advertise<sensor_msgs::CameraInfo>(entry.calibrated_info_topic, 1, true);
    cameras_.emplace(entry.camera.name, std::move(camera));
    fixed.push_back(entry.camera);
  }
  loadCameraTopics(cameras);
  survey_ = std::make_unique<Survey>(fixed, options);
  return true;
}

void CalibrationServer::loadCameraTopics(XmlRpc::XmlRpcValue& cameras)
{
  if (cameras.getType() == XmlRpc::XmlRpcValue::TypeStruct && cameras.hasMember("cameras"))
    return loadCameraTopics(cameras["cameras"]);
  if (cameras.getType() != XmlRpc::XmlRpcValue::TypeArray)
    return;
  for (int i = 0; i < cameras.size(); ++i)
  {
    const std::string name = stringMember(cameras[i], "name", "");
    const auto it = cameras_.find(name);
    if (it == cameras_.end())
      continue;
    Camera& camera = it->second;
    const std::string image_topic = stringMember(cameras[i], "image_topic", "/fixed/" + name + "/image_raw");
    // Beside the driver's own namespace, not in it: a driver usually publishes an uncalibrated camera_info there.
    camera.camera_info_topic =
        stringMember(cameras[i], "camera_info_topic", topicNamespace(image_topic) + "/calibrated/camera_info");
    camera.relay_image = boolMember(cameras[i], "relay_image", true);
    camera.set_camera_info_service = stringMember(cameras[i], "set_camera_info_service", "");
    ROS_INFO_STREAM(
        "calibration_node: " << name << ": camera info "
                             << (camera.camera_info_topic.empty() ? "off" : "on " + camera.camera_info_topic)
                             << (camera.relay_image ? " beside the relayed image" : "")
                             << (camera.set_camera_info_service.empty()
                                     ? ""
                                     : ", committed to " + camera.set_camera_info_service));
  }
}

void CalibrationServer::rgbdCallback(const sensor_msgs::ImageConstPtr& rgb, const sensor_msgs::ImageConstPtr& depth,
                                     const sensor_msgs::CameraInfoConstPtr& info)
{
  geometry_msgs::TransformStamped pose;
  try
  {
    pose =
        tf_buffer_.lookupTransform(world_frame_, rgb->header.frame_id, rgb->header.stamp, ros::Duration(tf_timeout_s_));
  }
  catch (const tf2::TransformException& e)
  {
    ROS_WARN_THROTTLE(5.0,
                      "calibration_node: skipping RGB-D frames: no pose of '%s' in '%s' at their stamp (%s). "
                      "Is the robot localised (map -> odom -> base_link) and the Xtion's tf published?",
                      rgb->header.frame_id.c_str(), world_frame_.c_str(), e.what());
    return;
  }
  auto converted = toRgbdFrame(*rgb, *depth, *info, tf2::transformToEigen(pose));
  if (!converted)
  {
    ROS_WARN_THROTTLE(5.0, "calibration_node: skipping RGB-D frames: %s", converted.error().message().c_str());
    return;
  }
  const RgbdFrame& frame = *converted;

  // Odometry, when tf has it, ties consecutive keyframes in the map adjustment.
  std::optional<Eigen::Isometry3d> odometry;
  if (!odom_frame_.empty() && tf_buffer_.canTransform(odom_frame_, rgb->header.frame_id, rgb->header.stamp))
    odometry = tf2::transformToEigen(tf_buffer_.lookupTransform(odom_frame_, rgb->header.frame_id, rgb->header.stamp));

  Expected<bool> used = false;
  std::vector<Segment2d> segments;  // a keyframe's, for the registration estimate
  {
    std::lock_guard<std::mutex> lock(mutex_);
    used = survey_->addRgbdFrame(frame, odometry, registration_estimator_ ? &segments : nullptr);
  }
  if (!used)
    ROS_WARN_THROTTLE(5.0, "calibration_node: skipping an RGB-D frame: %s", used.error().message().c_str());
  else if (*used && registration_estimator_)
    estimateDepthRegistration(frame, segments);
}

void CalibrationServer::estimateDepthRegistration(const RgbdFrame& keyframe, const std::vector<Segment2d>& segments)
{
  std::lock_guard<std::mutex> lock(registration_mutex_);
  if (registration_estimator_->addFrame(keyframe, segments, registration_rgbd_))
    solveDepthRegistration(0.25, false);
}

void CalibrationServer::settleDepthRegistration()
{
  if (!registration_estimator_)
    return;
  std::lock_guard<std::mutex> lock(registration_mutex_);
  solveDepthRegistration(0.0, true);
}

void CalibrationServer::solveDepthRegistration(double growth, bool log_any_growth)
{
  const auto due = registration_estimator_->estimateWhenGrown(growth);
  if (due && !*due)
  {
    registration_refused_ = due->error().message();
    const char* state = registration_estimate_ ? "not estimated again (the last estimate stands)" : "not estimated yet";
    if (log_any_growth)  // a calibration's settling solve: once per request, so always said
      ROS_INFO("calibration_node: depth registration %s: %s", state, registration_refused_.c_str());
    else
      ROS_INFO_THROTTLE(30.0, "calibration_node: depth registration %s: %s", state, registration_refused_.c_str());
  }
  if (!due || !*due)
    return;
  const auto& e = *due;
  registration_estimate_ = *e;
  registration_refused_.clear();
  const size_t log_from = log_any_growth ? registration_logged_creases_ + 1 : 2 * registration_logged_creases_;
  if (e->creases < log_from)
    return;
  registration_logged_creases_ = e->creases;
  const Eigen::Vector2d& used = registration_rgbd_.sampler.registration_offset_px;
  ROS_INFO(
      "calibration_node: depth registration estimated %.3f, %.3f px (1 sigma %.3f, %.3f px) from %zu creases in "
      "%zu keyframes, %.1f sigma from the %.3f, %.3f px in use; not applied to this survey: set "
      "depth_registration/x_px, y_px and sigma_px to it for the next",
      e->offset_px.x(), e->offset_px.y(), e->sigma_px.x(), e->sigma_px.y(), e->creases, e->frames,
      registrationDiscrepancySigmas(*e, used), used.x(), used.y());
}

std::string CalibrationServer::describeDepthRegistration()
{
  const Eigen::Vector2d& used = registration_rgbd_.sampler.registration_offset_px;
  char in_use[160];
  std::snprintf(in_use, sizeof(in_use), "in use %.3f, %.3f px (%s, 1 sigma %.2f px)", used.x(), used.y(),
                registration_given_ ? "given" : "default", registration_rgbd_.sampler.registration_sigma_px);
  if (!registration_estimator_)
    return std::string(in_use) + "; not estimated (depth_registration/estimate false)";
  std::lock_guard<std::mutex> lock(registration_mutex_);
  if (!registration_estimate_)
    return std::string(in_use) + "; " +
           (registration_refused_.empty() ? std::string("no estimate yet") : registration_refused_);
  const DepthRegistrationEstimate& e = *registration_estimate_;
  char estimated[200];
  std::snprintf(estimated, sizeof(estimated),
                "; estimated %.3f, %.3f px (1 sigma %.3f, %.3f px, %zu creases): %.1f sigma apart", e.offset_px.x(),
                e.offset_px.y(), e.sigma_px.x(), e.sigma_px.y(), e.creases, registrationDiscrepancySigmas(e, used));
  return in_use + std::string(estimated) +
         (registration_refused_.empty() ? "" : " (a later solve refused: " + registration_refused_ + ")");
}

std::string CalibrationServer::depthRegistrationWarning()
{
  if (!registration_estimator_)
    return "";
  std::lock_guard<std::mutex> lock(registration_mutex_);
  return registration_estimate_ ? registrationDisagreementAdvice(*registration_estimate_,
                                                                 registration_rgbd_.sampler.registration_offset_px)
                                : "";
}

void CalibrationServer::publishCalibratedInfo(const std::string& name, const sensor_msgs::ImageConstPtr& image)
{
  auto info = boost::make_shared<sensor_msgs::CameraInfo>();
  {
    std::lock_guard<std::mutex> lock(info_mutex_);
    const auto it = calibrated_info_.find(name);
    if (it == calibrated_info_.end())
      return;
    *info = it->second;
  }
  if (image->width != info->width || image->height != info->height)
  {
    ROS_WARN_THROTTLE(10.0,
                      "calibration_node: camera '%s': a %ux%u image, calibrated for %ux%u: no camera info "
                      "published with it",
                      name.c_str(), image->width, image->height, info->width, info->height);
    return;
  }
  // image_proc's synchronizer pairs exact stamps: the image's header, as a driver would publish it.
  info->header = image->header;
  Camera& camera = cameras_.at(name);  // the map's structure is fixed after construction
  if (camera.relay_image)
    camera.calibrated_publisher.publish(image, info);
  else
    camera.camera_info_publisher.publish(info);
}

std::string CalibrationServer::commitToDriver(const std::string& name, const sensor_msgs::CameraInfo& info)
{
  const std::string& service = cameras_.at(name).set_camera_info_service;
  if (service.empty())
    return "";
  sensor_msgs::SetCameraInfo srv;
  srv.request.camera_info = info;
  srv.request.camera_info.header.stamp = ros::Time();
  if (!ros::service::waitForService(service, ros::Duration(2.0)) || !ros::service::call(service, srv))
    return "; NOT committed: the driver's " + service + " does not answer";
  if (!srv.response.success)
    return "; NOT committed: " + service + " refused it (" + srv.response.status_message + ")";
  return "; committed to " + service;
}

void CalibrationServer::fixedImageCallback(const std::string& name, const sensor_msgs::ImageConstPtr& image)
{
  {
    std::lock_guard<std::mutex> lock(info_mutex_);
    last_image_[name] = ros::WallTime::now();
    ++image_count_[name];
  }
  if (!cameras_.at(name).camera_info_topic.empty())
    publishCalibratedInfo(name, image);
  const auto grey = toGrey(*image);
  if (!grey)
  {
    ROS_WARN_THROTTLE(5.0, "calibration_node: camera '%s': %s", name.c_str(), grey.error().message().c_str());
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  const auto added = survey_->addFixedImage(name, *grey, image->header.stamp.toSec());
  if (!added)
    ROS_WARN_THROTTLE(5.0, "calibration_node: camera '%s': %s", name.c_str(), added.error().message().c_str());
}

std::vector<std::string> CalibrationServer::selectCameras(const std::string& name, std::string* error) const
{
  std::vector<std::string> names;
  if (name.empty())
  {
    for (const auto& [n, camera] : cameras_)
      names.push_back(n);
    return names;
  }
  if (!cameras_.count(name))
  {
    std::string known;
    for (const auto& [n, camera] : cameras_)
      known += (known.empty() ? "" : ", ") + n;
    *error = "unknown camera '" + name + "' (configured: " + known + ")";
    return {};
  }
  return {name};
}

std::string CalibrationServer::calibrationPath(const std::string& name) const
{
  return output_directory_ + "/" + name + ".yaml";
}

Status CalibrationServer::saveCalibration(const std::string& name, std::string* kept_as)
{
  if (!survey_->camera(name).calibration())
    return Error(ErrorCode::kNotEnoughData, "camera '" + name + "' is not calibrated");
  // The overlay beside the YAML, for people; none after a restart (the image it was drawn on is gone): the store
  // then keeps the PNG already saved instead of replacing it by a blank one.
  const CalibrationFile& file = *survey_->camera(name).calibration();
  const cv::Mat image = survey_->camera(name).medianImage();
  const auto last = survey_->camera(name).lastResult();
  const cv::Mat overlay =
      image.empty() ? cv::Mat()
                    : drawCalibrationOverlay(
                          image, file.image_width, file.image_height, file.camera, survey_->latestMapSegments(),
                          last ? last->matched_image_lines : std::vector<std::vector<Eigen::Vector2d>>{});
  return CalibrationStore(output_directory_).save(name, file, overlay, kept_as);
}

void CalibrationServer::refreshMapAdjustment()
{
  std::lock_guard<std::mutex> serial(adjustment_mutex_);
  std::vector<Keyframe> keyframes;
  SurveyOptions options;
  uint64_t generation = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!survey_->adjustmentDue())
      return;
    keyframes = survey_->keyframes();
    options = survey_->options();
    generation = survey_->keyframeGeneration();
  }
  MapAdjustment adjustment = Survey::computeAdjustment(keyframes, options, generation);
  const double cpu_ms = adjustment.cpu_ms;
  std::lock_guard<std::mutex> lock(mutex_);
  if (survey_->installAdjustment(std::move(adjustment)))
    ROS_DEBUG_STREAM("calibration_node: line map adjusted with " << keyframes.size() << " keyframes in " << cpu_ms
                                                                 << " ms of CPU");
}

void CalibrationServer::reportFailure(const std::string& name, const FixedCamera& camera,
                                      const std::vector<Segment3d>& map, const Error& error,
                                      CalibrationOutcome* outcome)
{
  insitu_calibration::CalibrationResult failed;
  failed.camera_name = name;
  failed.success = false;
  failed.message = publishSurveyGuidance(name, camera, map, error);
  outcome->results.push_back(failed);
  outcome->success = false;
  outcome->message += name + ": FAILED: " + failed.message + "\n";
  ROS_WARN_STREAM("calibration_node: " << name << ": calibration failed: " << failed.message);
}

CalibrationMap CalibrationServer::extendedMap(const std::function<void(const std::string&)>& stage)
{
  std::vector<Keyframe> keyframes;
  std::vector<PoseCorrection> corrections;
  SurveyOptions options;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    options = survey_->options();
    if (!extendedRetryAdds(options))
      return {};
    keyframes = survey_->keyframes();
    corrections = survey_->latestPoseCorrections();
  }
  stage("retrying on the extended map");
  const LineMap extended = Survey::computeExtendedMap(keyframes, corrections, options);
  std::lock_guard<std::mutex> lock(mutex_);
  return survey_->calibrationMapOf(extended, true);
}

void CalibrationServer::calibrateOne(const std::string& name, const std::function<void(const std::string&)>& stage,
                                     CalibrationOutcome* outcome)
{
  std::optional<FixedCamera> camera;
  CalibrationMap in_use;
  uint64_t generation = 0;
  size_t keyframes = 0;
  refreshMapAdjustment();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    camera.emplace(survey_->camera(name));
    camera->setOccluders(survey_->surfaces());
    survey_->useSurveyCeiling(*camera);
    keyframes = survey_->stats().keyframes;
    in_use = survey_->calibrationMapOf(survey_->latestLineMap());
    generation = reset_generation_;
  }
  const std::optional<CalibrationFile> previous = camera->calibration();
  stage("calibrating");
  CalibrationMap used;  // its lines' shared errors widen the result's sigmas
  // The long part, without mutex_ (the extended map too: only its keyframes are copied under it).
  auto result = calibrateWithExtendedRetry(
      *camera, world_frame_, in_use, [&]() { return extendedMap(stage); }, &used);
  const std::vector<Segment3d>& map = used.segments;
  if (!result)
  {
    stage("survey guidance");
    reportFailure(name, *camera, map, result.error(), outcome);
    return;
  }
  forgetSurveyGuidance(name);
  {
    // The map's placement in world_frame_ (the localiser's error over the survey) and the errors the used map lines'
    // observations share widen the sigmas.
    std::lock_guard<std::mutex> lock(mutex_);
    if (survey_->addMapPlacement(&*result, used.lines))
      camera->setCalibration(result->file);
  }
  auto msg = toResultMsg(result->file, &result->calibration, world_frame_);
  msg.message = result->summary;
  const std::string change_note = notePreviousCalibration(previous, result->file, map, &msg);
  stage("saving");
  const cv::Mat image = camera->medianImage();  // for the report, drawn after the lock
  const FixedCameraConfig config = camera->config();
  std::string saved_note = "saved to " + calibrationPath(name);
  bool saved_ok = true;
  std::string kept_as;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (generation != reset_generation_)
    {
      msg.success = false;
      msg.message = "discarded: the camera was reset during its calibration";
      outcome->results.push_back(msg);
      outcome->success = false;
      outcome->message += name + ": " + msg.message + "\n";
      return;
    }
    camera->setOccluders(nullptr);  // its snapshot of the voxels is done with (a holder makes keyframes copy them)
    survey_->camera(name) = std::move(*camera);
    if (const Status saved = saveCalibration(name, &kept_as); !saved)
    {
      saved_ok = false;
      saved_note = "NOT saved: " + saved.error().message();
      ROS_ERROR_STREAM("calibration_node: " << name << ": " << saved.error().message());
    }
  }
  forgetMotion(name);  // the watchdog's last check was of the calibration replaced
  if (write_report_ && saved_ok)
    writeReport(output_directory_, config, *result, image, map, keyframes);
  msg.previous_kept_as = kept_as;
  if (!kept_as.empty())
    saved_note += " (the previous calibration kept as " + kept_as + ")";
  saved_note += commitToDriver(name, toCameraInfo(result->file, cameras_.at(name).optical_frame));
  outcome->results.push_back(msg);
  const std::string saved_sigma = result->file.quality ? describeSavedSigma(result->file.quality->extra) : "";
  const std::string summary = result->summary + (saved_sigma.empty() ? "" : "; " + saved_sigma);
  outcome->message += name + ": " + summary + change_note + "; " + saved_note + "\n";
  ROS_INFO_STREAM("calibration_node: " << name << ": " << summary);
}

CalibrationServer::CalibrationOutcome CalibrationServer::calibrateCameras(const std::vector<std::string>& names,
                                                                          const Progress& progress,
                                                                          const std::function<bool()>& cancelled)
{
  auto report = [&](const std::string& camera, const std::string& stage, size_t done) {
    if (progress)
      progress(camera, stage, done, names.size());
  };
  report(names.front(), "waiting", 0);
  std::lock_guard<std::mutex> serial(calibration_mutex_);
  CalibrationOutcome outcome;
  for (size_t i = 0; i < names.size(); ++i)
  {
    if (cancelled && cancelled())
    {
      outcome.cancelled = true;
      outcome.success = false;
      outcome.message += "cancelled before " + names[i] + "\n";
      break;
    }
    calibrateOne(
        names[i], [&](const std::string& stage) { report(names[i], stage, i); }, &outcome);
  }
  settleDepthRegistration();
  if (const std::string warning = depthRegistrationWarning(); !warning.empty())
  {
    ROS_WARN_STREAM("calibration_node: " << warning);
    outcome.message += "note: " + warning + "\n";
  }
  if (!outcome.message.empty() && outcome.message.back() == '\n')
    outcome.message.pop_back();
  publishCalibrations();
  publishSurveyStatus();
  report("", "done", outcome.results.size());
  return outcome;
}

bool CalibrationServer::calibrateService(Calibrate::Request& request, Calibrate::Response& response)
{
  std::string error;
  const std::vector<std::string> names = selectCameras(request.camera, &error);  // cameras_ is fixed: no lock
  if (names.empty())
    return refuseRequest(response, error);
  const CalibrationOutcome outcome = calibrateCameras(names, nullptr, nullptr);
  response.success = outcome.success;
  response.message = outcome.message;
  response.results = outcome.results;
  return true;
}

void CalibrationServer::executeCalibrateAction(const CalibrateGoalConstPtr& goal)
{
  CalibrateResult result;
  std::string error;
  const std::vector<std::string> names = selectCameras(goal->camera, &error);
  if (names.empty())
  {
    result.success = false;
    result.message = error;
    calibrate_action_->setAborted(result, error);
    return;
  }
  const CalibrationOutcome outcome = calibrateCameras(
      names,
      [this](const std::string& camera, const std::string& stage, size_t done, size_t total) {
        CalibrateFeedback feedback;
        feedback.camera = camera;
        feedback.stage = stage;
        feedback.cameras_done = static_cast<uint32_t>(done);
        feedback.cameras_total = static_cast<uint32_t>(total);
        feedback.progress = total > 0 ? static_cast<float>(done) / total : 1.0f;
        calibrate_action_->publishFeedback(feedback);
      },
      [this] { return calibrate_action_->isPreemptRequested() || !ros::ok(); });
  result.success = outcome.success;
  result.message = outcome.message;
  result.results = outcome.results;
  if (outcome.cancelled)
    calibrate_action_->setPreempted(result, outcome.message);
  else if (outcome.success)
    calibrate_action_->setSucceeded(result, outcome.message);
  else
    calibrate_action_->setAborted(result, outcome.message);
}

bool CalibrationServer::statusService(CalibrationStatus::Request& request, CalibrationStatus::Response& response)
{
  std::string error;
  const std::vector<std::string> names = selectCameras(request.camera, &error);  // cameras_ is fixed: no lock
  if (names.empty())
    return refuseRequest(response, error);
  response.success = true;
  response.cameras = cameraStatuses(names, &response.message);
  return true;
}

bool CalibrationServer::resetService(Reset::Request& request, Reset::Response& response)
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (request.camera.empty())
  {
    survey_->reset();
    ++reset_generation_;
    forgetMotion("");
    {
      std::lock_guard<std::mutex> info_lock(info_mutex_);
      calibrated_info_.clear();
    }
    response.success = true;
    response.message = "reset every camera and the 3D line map (saved files are kept)";
    return true;
  }
  std::string error;
  if (selectCameras(request.camera, &error).empty())
    return refuseRequest(response, error);
  survey_->resetCamera(request.camera);
  ++reset_generation_;
  forgetMotion(request.camera);
  {
    std::lock_guard<std::mutex> info_lock(info_mutex_);
    calibrated_info_.erase(request.camera);
  }
  response.success = true;
  response.message = "reset camera '" + request.camera + "' (its saved file is kept)";
  return true;
}

bool CalibrationServer::saveService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response)
{
  std::lock_guard<std::mutex> lock(mutex_);
  response.success = true;
  size_t saved = 0;
  for (const auto& [name, camera] : cameras_)
  {
    if (!survey_->camera(name).calibration())
      continue;
    if (const Status s = saveCalibration(name); !s)
    {
      response.success = false;
      response.message += name + ": " + s.error().message() + "; ";
      continue;
    }
    ++saved;
    // ... and committed again to the drivers configured for it (a driver that was down at calibration time).
    const std::string committed =
        commitToDriver(name, toCameraInfo(*survey_->camera(name).calibration(), camera.optical_frame));
    if (committed.rfind("; NOT", 0) == 0)
      response.success = false;
    response.message += committed.empty() ? "" : name + committed.substr(1) + "; ";
  }
  response.message += std::to_string(saved) + " calibration(s) saved in " + output_directory_;
  return true;
}

void CalibrationServer::publishCalibrations()
{
  // A snapshot under mutex_ (FixedCamera copies share their images); the median images, overlays and publishing
  // without it, so that ~status and the image callbacks do not wait for the drawing. The caller must not hold it.
  std::vector<std::pair<std::string, FixedCamera>> calibrated;
  std::vector<Segment3d> map;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    map = survey_->latestMapSegments();
    for (const auto& [name, camera] : cameras_)
      if (survey_->camera(name).calibration())
        calibrated.emplace_back(name, survey_->camera(name));
    publishMarkers();
  }
  std::vector<geometry_msgs::TransformStamped> transforms;
  const ros::Time now = ros::Time::now();
  for (const auto& [name, fixed] : calibrated)
  {
    Camera& camera = cameras_.at(name);
    const CalibrationFile& calibration = *fixed.calibration();
    const auto t = cameraTransforms(calibration, world_frame_, camera.link_frame, camera.optical_frame, now);
    transforms.insert(transforms.end(), t.begin(), t.end());
    sensor_msgs::CameraInfo info = toCameraInfo(calibration, camera.optical_frame);
    info.header.stamp = now;
    camera.info_publisher.publish(info);
    {
      std::lock_guard<std::mutex> lock(info_mutex_);
      calibrated_info_[name] = info;
    }
    const auto& last = fixed.lastResult();
    const cv::Mat overlay = drawCalibrationOverlay(
        fixed.medianImage(), calibration.image_width, calibration.image_height, calibration.camera, map,
        last ? last->matched_image_lines : std::vector<std::vector<Eigen::Vector2d>>{});
    std_msgs::Header header;
    header.stamp = now;
    header.frame_id = camera.optical_frame;
    camera.overlay_publisher.publish(cv_bridge::CvImage(header, "bgr8", overlay).toImageMsg());
  }
  // One broadcaster for every camera: it republishes all its transforms together on the latched /tf_static.
  if (!transforms.empty())
    static_broadcaster_.sendTransform(transforms);
}

void CalibrationServer::publishMarkers()
{
  visualization_msgs::MarkerArray markers;
  markers.markers.push_back(
      lineList(world_frame_, "line_map", 0, survey_->latestMapSegments(), 0.75f, 0.75f, 0.75f, 0.01));
  int id = 0;
  for (const auto& [name, camera] : cameras_)
  {
    ++id;
    const auto& calibration = survey_->camera(name).calibration();
    const auto last = survey_->camera(name).lastResult();
    markers.markers.push_back(lineList(world_frame_, "matched", id,
                                       last ? last->matched_map_lines : std::vector<Segment3d>{}, 0.2f, 0.9f, 0.2f,
                                       0.02));
    markers.markers.push_back(lineList(
        world_frame_, "frustum", id,
        calibration ? frustumSegments(calibration->camera, calibration->image_width, calibration->image_height, 1.0)
                    : std::vector<Segment3d>{},
        0.2f, 0.5f, 1.0f, 0.015));
    visualization_msgs::Marker label;
    label.header.frame_id = world_frame_;
    label.ns = "camera_name";
    label.id = id;
    label.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    label.action = calibration ? visualization_msgs::Marker::ADD : visualization_msgs::Marker::DELETE;
    label.pose.orientation.w = 1.0;
    if (calibration)
      label.pose.position = toPointMsg(calibration->camera.pose().center() + Eigen::Vector3d(0, 0, 0.3));
    label.scale.z = 0.3;  // m: readable from rviz's default view of a room (0.15 was a few pixels high)
    label.color.r = label.color.g = label.color.b = label.color.a = 1.0;
    label.text = name;
    markers.markers.push_back(label);
    addSurveyHintMarkers(name, id, &markers);
  }
  marker_publisher_.publish(markers);
}

void CalibrationServer::loadSavedCalibrations()
{
  const CalibrationStore store(output_directory_);
  std::vector<std::string> names;
  for (const auto& entry : cameras_)
    names.push_back(entry.first);
  for (const std::string& removed : store.removeStaleTemporaries(names))
    ROS_WARN_STREAM("calibration_node: removed " << removed << ", left by a save that was interrupted");
  size_t loaded = 0;
  for (const std::string& name : names)
  {
    const FixedCameraConfig& config = survey_->camera(name).config();
    const CalibrationStore::Loaded saved = store.load(name, config.image_width, config.image_height);
    if (!saved.problem.empty())
      ROS_ERROR_STREAM("calibration_node: not using the saved calibration of '" << name << "': " << saved.problem);
    if (!saved.calibration)
      continue;
    survey_->camera(name).setCalibration(*saved.calibration);
    ++loaded;
    ROS_INFO_STREAM("calibration_node: loaded the calibration of '" << name << "' from "
                                                                    << store.calibrationPath(name));
  }
  if (loaded > 0)
    publishCalibrations();
}

}  // namespace insitu_calibration
