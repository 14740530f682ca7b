// The calibration node's ROS side: parameters, subscriptions (Xtion RGB-D with tf2 poses, fixed cameras through
// image_transport), services (~calibrate, ~status, ~reset, ~save, ~verify), the ~calibrate action, the moved-camera
// watchdog (every verify_period_s), and outputs (one static tf
// broadcaster, latched and per-image CameraInfo, YAML files, markers, overlay images, /diagnostics, the latched
// ~survey_status). The work is done by the core (RgbdLineExtractor, LineMap, FixedCamera); this class converts and
// calls.
#ifndef INSITU_CALIBRATION_ROS_CALIBRATION_SERVER_H
#define INSITU_CALIBRATION_ROS_CALIBRATION_SERVER_H

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <actionlib/server/simple_action_server.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/Config.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <image_transport/image_transport.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/SetCameraInfo.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include "insitu_calibration/Calibrate.h"
#include "insitu_calibration/CalibrateAction.h"
#include "insitu_calibration/Reset.h"
#include "insitu_calibration/CalibrationStatus.h"
#include "insitu_calibration/SurveyStatus.h"
#include "insitu_calibration/Verify.h"
#include "insitu_calibration/lines/depth_registration.h"
#include "insitu_calibration/ros/parameter_reader.h"
#include "insitu_calibration/survey/field_thresholds.h"
#include "insitu_calibration/survey/survey.h"
#include "insitu_calibration/survey/survey_guidance.h"

namespace insitu_calibration
{
class CalibrationServer
{
public:
  CalibrationServer(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~CalibrationServer();
  // False when the configuration could not be loaded (the reason went to ROS_FATAL): the node must exit non-zero.
  bool ok() const { return survey_ != nullptr; }

private:
  // The registration estimate for the diagnostics, and a warning (empty when none is due) when the offset in use
  // lies more than 3 sigma from it.
  std::string describeDepthRegistration();
  std::string depthRegistrationWarning();
  // With depth_registration/estimate: a keyframe's creases into the estimate, solved again when they have grown by a
  // quarter, logged when it is first determined and whenever its creases have doubled since.
  void estimateDepthRegistration(const RgbdFrame& keyframe, const std::vector<Segment2d>& segments);
  // Solves again with every crease found so far (growth 0: any new one), so that a calibration's note and log state
  // the whole survey's estimate, not that of the last quarter's growth; logged when its creases grew at all.
  void settleDepthRegistration();
  // Under registration_mutex_: solves when the creases grew by `growth` since the last solve, logs as stated above.
  void solveDepthRegistration(double growth, bool log_any_growth);
  // The ROS side of a fixed camera; its core is survey_->camera(name).
  struct Camera
  {
    image_transport::Subscriber subscriber;
    ros::Publisher info_publisher;  // latched, once per calibration (calibrated_info_topic)
    // Latched, so plain ros::Publishers: image_transport's publishes only to transports with a subscriber at the
    // time (image_common #209), so the overlay of a calibration made before rviz started was never seen ("No Image").
    ros::Publisher overlay_publisher;
    ros::Publisher survey_hint_publisher;  // the last refusal's guidance
    std::string link_frame;
    std::string optical_frame;
    // The camera info that image_proc pairs with each image (same header), on camera_info_topic; with relay_image
    // the image itself too, beside it (image_raw), so that image_proc runs in that namespace with no remapping.
    std::string camera_info_topic;
    bool relay_image = true;
    image_transport::CameraPublisher calibrated_publisher;  // relay_image
    ros::Publisher camera_info_publisher;                   // !relay_image
    // When set, every new calibration is committed to the camera driver (camera_calibration's "commit").
    std::string set_camera_info_service;
  };

  // False after a configuration error, each reported as ROS_FATAL.
  bool loadParameters();
  SurveyOptions readParameters(ParameterReader& read);
  void rgbdCallback(const sensor_msgs::ImageConstPtr& rgb, const sensor_msgs::ImageConstPtr& depth,
                    const sensor_msgs::CameraInfoConstPtr& info);
  void fixedImageCallback(const std::string& name, const sensor_msgs::ImageConstPtr& image);
  // The per-camera ROS options of the ~cameras entries (the core parser ignores them).
  void loadCameraTopics(XmlRpc::XmlRpcValue& cameras);
  // The calibrated camera info with the image's header, and the image itself when relayed; no-op before a
  // calibration. Needs only info_mutex_, so images keep flowing while a calibration holds mutex_.
  void publishCalibratedInfo(const std::string& name, const sensor_msgs::ImageConstPtr& image);
  // Sends the calibration to the driver's set_camera_info service, when configured. Returns what happened, in words.
  std::string commitToDriver(const std::string& name, const sensor_msgs::CameraInfo& info);

  // A calibration of some cameras, shared by the ~calibrate service and action. Each camera is calibrated on a copy
  // of its FixedCamera outside mutex_ (so ~status, images and RGB-D frames go on meanwhile), and the copy replaces
  // it unless the camera was reset in between. One calibration at a time (calibration_mutex_).
  struct CalibrationOutcome
  {
    bool success = true;
    bool cancelled = false;
    std::string message;
    std::vector<insitu_calibration::CalibrationResult> results;
  };
  using Progress = std::function<void(const std::string& camera, const std::string& stage, size_t done, size_t total)>;
  CalibrationOutcome calibrateCameras(const std::vector<std::string>& names, const Progress& progress,
                                      const std::function<bool()>& cancelled);
  void calibrateOne(const std::string& name, const std::function<void(const std::string&)>& stage,
                    CalibrationOutcome* outcome);
  // The extended map of the survey's keyframes for a refused camera's retry (extended_retry), built without
  // mutex_; an empty map when the retry is off or adds nothing.
  CalibrationMap extendedMap(const std::function<void(const std::string&)>& stage);
  // A refused calibration: the survey guidance published and the refusal added to the outcome.
  void reportFailure(const std::string& name, const FixedCamera& camera, const std::vector<Segment3d>& map,
                     const Error& error, CalibrationOutcome* outcome);
  void executeCalibrateAction(const CalibrateGoalConstPtr& goal);
  // Adjusts the line map with the keyframe poses (seconds of CPU on a long survey) on a copy of the keyframes,
  // without mutex_, so that images, RGB-D frames and ~status go on meanwhile; no-op when the map is current.
  // Before every calibration and every map_adjustment_period_s during a survey (adjustment_timer_).
  void refreshMapAdjustment();

  bool calibrateService(Calibrate::Request& request, Calibrate::Response& response);

  // Status reporting (calibration_server_status.cpp): /diagnostics per camera and for the survey, the latched
  // ~survey_status topic, and the per-camera status that ~status and the topic share.
  void setupStatusReporting();
  std::vector<CameraStatus> cameraStatuses(const std::vector<std::string>& names, std::string* summary,
                                           SurveyStatus* survey = nullptr);
  void publishSurveyStatus();
  void cameraDiagnostics(const std::string& name, diagnostic_updater::DiagnosticStatusWrapper& stat);
  void surveyDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);
  bool statusService(CalibrationStatus::Request& request, CalibrationStatus::Response& response);
  bool resetService(Reset::Request& request, Reset::Response& response);
  bool saveService(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);

  // The moved-camera watchdog (calibration_server_watchdog.cpp): ~verify and the periodic check, both on the work
  // queue (behind a calibration, never beside it), each a check of the calibration against the median of the
  // camera's recent images (FixedCamera::verify) without mutex_. The last result per camera feeds /diagnostics and
  // ~status; a new calibration or a reset forgets it.
  void setupWatchdog();
  Expected<CameraMotion> verifyCamera(const std::string& name);
  void verifyCalibratedCameras();
  bool verifyService(Verify::Request& request, Verify::Response& response);
  std::optional<CameraMotion> lastMotion(const std::string& name);
  void forgetMotion(const std::string& name);
  // A copy of the thresholds, taken under mutex_ (they change at runtime).
  FieldThresholds thresholds() const;

  // dynamic_reconfigure (calibration_server_reconfigure.cpp): the field-tuned thresholds (field_thresholds.h) through
  // dynamic_reconfigure's protocol (~set_parameters, ~parameter_descriptions, ~parameter_updates). Its own server,
  // not dynamic_reconfigure::Server, which clamps a value out of range instead of refusing it.
  void setupReconfigure();
  bool reconfigureService(dynamic_reconfigure::Reconfigure::Request& request,
                          dynamic_reconfigure::Reconfigure::Response& response);
  // The thresholds as dynamic_reconfigure's message (call under mutex_).
  dynamic_reconfigure::Config reconfigureState() const;
  // Makes new thresholds current: the survey's cameras and the watchdog's timer follow (call under mutex_).
  void applyThresholds(const FieldThresholds& thresholds);

  // Publishes every calibration: tf (one broadcaster, all cameras at once), CameraInfo, markers, overlays. Takes
  // mutex_ itself (only for a snapshot): the caller must not hold it.
  void publishCalibrations();
  void publishMarkers();
  // Survey guidance after a refusal (calibration_server_guidance.cpp): computed on the refused copy of the camera
  // (without mutex_, which the caller must not hold), saved and published; returns the refusal's message with it.
  std::string publishSurveyGuidance(const std::string& name, const FixedCamera& camera,
                                    const std::vector<Segment3d>& map, const Error& error);
  void forgetSurveyGuidance(const std::string& name);  // after a calibration: its markers go
  // The camera's survey_hint markers (a floor polygon and a standpoint arrow per region; DELETE for the unused
  // ids). The caller holds mutex_.
  void addSurveyHintMarkers(const std::string& name, int camera_id, visualization_msgs::MarkerArray* markers) const;
  void loadSavedCalibrations();
  // kept_as: where the calibration it replaced was kept (CalibrationStore::save).
  Status saveCalibration(const std::string& name, std::string* kept_as = nullptr);
  std::string calibrationPath(const std::string& name) const;
  std::vector<std::string> selectCameras(const std::string& name, std::string* error) const;

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  image_transport::ImageTransport it_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;

  using SyncPolicy =
      message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::Image, sensor_msgs::CameraInfo>;
  message_filters::Subscriber<sensor_msgs::Image> rgb_subscriber_;
  message_filters::Subscriber<sensor_msgs::Image> depth_subscriber_;
  message_filters::Subscriber<sensor_msgs::CameraInfo> info_subscriber_;
  std::unique_ptr<message_filters::Synchronizer<SyncPolicy>> synchronizer_;

  // Services and the action's goals run on their own queue and thread (service_spinner_), calibrations on the
  // ~calibrate service's thread (work_spinner_) or the action's own: neither waits behind the image callbacks of
  // the global queue, nor ~status behind a calibration. The periodic reports (/diagnostics, ~survey_status) have
  // a queue and thread of their own (report_spinner_): ~survey_status does ~status's work for every camera, and a
  // service call must not wait behind it.
  ros::CallbackQueue service_queue_;
  ros::CallbackQueue work_queue_;
  ros::CallbackQueue report_queue_;
  ros::NodeHandle service_nh_;  // private namespace, service_queue_
  ros::NodeHandle work_nh_;     // private namespace, work_queue_
  ros::NodeHandle report_nh_;   // private namespace, report_queue_
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
  std::unique_ptr<ros::AsyncSpinner> work_spinner_;
  std::unique_ptr<ros::AsyncSpinner> report_spinner_;
  std::unique_ptr<actionlib::SimpleActionServer<CalibrateAction>> calibrate_action_;
  std::mutex calibration_mutex_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diagnostics_timer_;
  ros::WallTimer survey_status_timer_;
  ros::Publisher survey_status_publisher_;
  double status_period_s_ = 5.0;   // ~survey_status's period (0: only after calibrations)
  uint64_t reset_generation_ = 0;  // guarded by mutex_; a calibration started before a reset is discarded

  ros::ServiceServer calibrate_server_;
  ros::ServiceServer status_server_;
  ros::ServiceServer reset_server_;
  ros::ServiceServer save_server_;
  ros::ServiceServer verify_server_;
  ros::WallTimer verify_timer_;  // stopped while thresholds_.verify_period_s is 0
  std::mutex motion_mutex_;
  std::map<std::string, CameraMotion> last_motion_;  // per camera, the watchdog's last check (motion_mutex_)
  ros::Publisher marker_publisher_;
  ros::WallTimer marker_timer_;
  ros::WallTimer adjustment_timer_;
  std::mutex adjustment_mutex_;  // one adjustment at a time

  // Parameters
  std::string world_frame_;
  std::string odom_frame_;  // empty: no odometry for the map adjustment
  std::string output_directory_;
  double tf_timeout_s_ = 0.2;
  double map_adjustment_period_s_ = 10.0;  // 0: only before a calibration
  bool write_report_ = true;               // <name>_report.html beside the YAML on every calibration
  // depth_registration/estimate (default: unless the parameters give the offset): the Xtion's depth-to-RGB
  // misregistration estimated from the keyframes' creases, logged with its sigma and shown in the diagnostics (not
  // applied: the keyframes already in the map were read without it; the operator sets depth_registration/x_px, y_px
  // for the next survey, and a calibration warns when the offset in use is far from it). The estimate belongs to the
  // sensor, so ~reset keeps it. registration_estimator_ (the pointer), registration_rgbd_ and registration_given_ are
  // set once in readParameters, before any callback; the estimator's state and the members after them are guarded by
  // registration_mutex_ (the RGB-D callbacks).
  std::mutex registration_mutex_;
  std::unique_ptr<DepthRegistrationEstimator> registration_estimator_;
  RgbdLineOptions registration_rgbd_;       // the survey's extraction options (its depth range, the offset in use)
  bool registration_given_ = false;         // the parameters gave the offset in use
  size_t registration_logged_creases_ = 0;  // creases behind the last logged estimate
  std::optional<DepthRegistrationEstimate> registration_estimate_;  // the latest determined one
  std::string registration_refused_;  // why the latest solve gave none (empty once it gave one)
  ros::ServiceServer reconfigure_server_;
  ros::Publisher reconfigure_descriptions_publisher_;
  ros::Publisher reconfigure_updates_publisher_;

  // State, guarded by mutex_ (callbacks run on an AsyncSpinner's threads).
  mutable std::mutex mutex_;
  std::unique_ptr<Survey> survey_;
  // The field-tuned thresholds (dynamic_reconfigure): the watchdog's, /diagnostics', and the cameras' (a copy of
  // the survey's camera options, kept in step by applyThresholds).
  FieldThresholds thresholds_;
  std::map<std::string, Camera> cameras_;
  std::map<std::string, SurveyGuidance> survey_guidance_;  // per refused camera, its last guidance
  // Each calibrated camera's CameraInfo (header filled per image), written under both locks, read under info_mutex_.
  std::mutex info_mutex_;
  std::map<std::string, sensor_msgs::CameraInfo> calibrated_info_;
  std::map<std::string, ros::WallTime> last_image_;  // per camera, when its last image arrived (info_mutex_)
  std::map<std::string, size_t> image_count_;        // per camera, images received (info_mutex_)
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ROS_CALIBRATION_SERVER_H
