// calibration_node_async.test: the node answers while it works. During a calibration (the ~calibrate action,
// started while the survey bag still plays) ~status answers within a second and the fixed cameras' images keep
// reaching the survey; the action reports its stages; a cancelled action stops between cameras; the service still
// calibrates afterwards.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <mutex>
#include <map>
#include <optional>
#include <set>

#include <actionlib/client/simple_action_client.h>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/ros.h>

#include "insitu_calibration/Calibrate.h"
#include "insitu_calibration/CalibrateAction.h"
#include "insitu_calibration/CalibrationStatus.h"
#include "insitu_calibration/SurveyStatus.h"

namespace ic = insitu_calibration;
using Client = actionlib::SimpleActionClient<ic::CalibrateAction>;

namespace
{
double g_bag_start = 0.0;
double g_bag_end = 0.0;

// The last /diagnostics status of each name, and the last ~survey_status.
std::mutex g_mutex;
std::map<std::string, diagnostic_msgs::DiagnosticStatus> g_diagnostics;
ic::SurveyStatusConstPtr g_survey_status;

std::optional<diagnostic_msgs::DiagnosticStatus> diagnostics(const std::string& name)
{
  std::lock_guard<std::mutex> lock(g_mutex);
  const auto it = g_diagnostics.find(name);
  return it == g_diagnostics.end() ? std::nullopt : std::optional<diagnostic_msgs::DiagnosticStatus>(it->second);
}

// Waits for the simulated clock (the bag's) to pass a time.
bool waitForSimTime(double t, double wall_timeout_s)
{
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(wall_timeout_s);
  while (ros::ok() && ros::WallTime::now() < deadline)
  {
    if (ros::Time::now().toSec() >= t)
      return true;
    ros::WallDuration(0.1).sleep();
  }
  return false;
}

size_t fixedImages(const ic::CalibrationStatus::Response& status)
{
  size_t images = 0;
  for (const auto& camera : status.cameras)
    images += camera.images;
  return images;
}

// Feedback seen by an action client.
struct Feedback
{
  std::mutex mutex;
  std::vector<ic::CalibrateFeedback> messages;
  void add(const ic::CalibrateFeedbackConstPtr& f)
  {
    std::lock_guard<std::mutex> lock(mutex);
    messages.push_back(*f);
  }
  std::set<std::string> stages()
  {
    std::lock_guard<std::mutex> lock(mutex);
    std::set<std::string> out;
    for (const auto& f : messages)
      out.insert(f.stage);
    return out;
  }
};
}  // namespace

// While the bag plays (half of it left: the fixed cameras send an image every 5 s, and with a quarter left the bag
// could end before the action began on a loaded machine), calibrate every camera through the action; meanwhile poll
// ~status.
TEST(CalibrationNodeAsync, StatusAndImagesFlowDuringTheAction)
{
  Client client("/calibration_node/calibrate", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(60.0))) << "no ~calibrate action server";
  ASSERT_TRUE(waitForSimTime(g_bag_start + 0.5 * (g_bag_end - g_bag_start), 300.0)) << "the bag did not play";
  // ~status's own time (it extracts the lines of each camera's median image), without a calibration running.
  ic::CalibrationStatus before;
  double idle_status_s = 0.0;
  for (int i = 0; i < 3; ++i)
  {
    const ros::WallTime asked = ros::WallTime::now();
    ASSERT_TRUE(ros::service::call("/calibration_node/status", before));
    idle_status_s = std::max(idle_status_s, (ros::WallTime::now() - asked).toSec());
  }

  Feedback feedback;
  ic::CalibrateGoal goal;  // every camera
  const ros::WallTime start = ros::WallTime::now();
  client.sendGoal(goal, Client::SimpleDoneCallback(), Client::SimpleActiveCallback(),
                  [&](const ic::CalibrateFeedbackConstPtr& f) { feedback.add(f); });
  double slowest_status_s = 0.0;
  size_t status_calls = 0, images_during = 0;
  // Wall-clock polling: the simulated clock stops with the bag.
  while (!client.getState().isDone() && ros::WallTime::now() - start < ros::WallDuration(600.0))
  {
    const ros::WallTime asked = ros::WallTime::now();
    ic::CalibrationStatus status;
    ASSERT_TRUE(ros::service::call("/calibration_node/status", status));
    slowest_status_s = std::max(slowest_status_s, (ros::WallTime::now() - asked).toSec());
    ++status_calls;
    images_during = std::max(images_during, fixedImages(status.response));
    ros::WallDuration(0.2).sleep();
  }
  const double took_s = (ros::WallTime::now() - start).toSec();
  ASSERT_TRUE(client.getState().isDone()) << "the action did not finish";
  const auto result = client.getResult();
  std::printf(
      "action: %.1f s, %s; %zu ~status calls during it, slowest %.3f s (%.3f s without a calibration); fixed "
      "images in the survey %zu -> %zu; %zu feedback messages\n",
      took_s, client.getState().toString().c_str(), status_calls, slowest_status_s, idle_status_s,
      fixedImages(before.response), images_during, feedback.messages.size());
  std::printf("%s\n", result->message.c_str());
  EXPECT_EQ(result->results.size(), 3u);
  EXPECT_GE(status_calls, 5u) << "the calibration was too short to say anything";
  // Before, ~status waited for the whole calibration; now it must not wait even for one camera's: it takes its own
  // time (median image and lines) and at most one RGB-D keyframe's (mutex_). Half a camera's calibration time as
  // the bound: the machine's load scales both alike.
  EXPECT_LT(slowest_status_s, 0.5 * took_s / 3) << "~status waited for a calibration";
  EXPECT_GT(images_during, fixedImages(before.response)) << "no fixed image reached the survey during the calibration";
  const auto stages = feedback.stages();
  for (const char* stage : {"calibrating", "done"})
    EXPECT_TRUE(stages.count(stage)) << "no '" << stage << "' feedback";
  EXPECT_GE(feedback.messages.size(), 4u);
}

// After the bag: an action for every camera, cancelled once the first camera is being calibrated, stops before the
// last camera and says so.
TEST(CalibrationNodeAsync, CancelStopsBetweenCameras)
{
  ASSERT_TRUE(waitForSimTime(g_bag_end - 1.0, 300.0));  // the bag's last message is a little before its end
  Client client("/calibration_node/calibrate", true);
  ASSERT_TRUE(client.waitForServer(ros::Duration(30.0)));
  Feedback feedback;
  bool cancelled = false;
  client.sendGoal(ic::CalibrateGoal(), Client::SimpleDoneCallback(), Client::SimpleActiveCallback(),
                  [&](const ic::CalibrateFeedbackConstPtr& f) {
                    feedback.add(f);
                    if (f->stage == "calibrating" && !cancelled)
                    {
                      cancelled = true;
                      client.cancelGoal();
                    }
                  });
  const ros::WallTime start = ros::WallTime::now();
  while (!client.getState().isDone() && ros::WallTime::now() - start < ros::WallDuration(300.0))
    ros::WallDuration(0.1).sleep();
  ASSERT_TRUE(client.getState().isDone());
  const auto result = client.getResult();
  std::printf("cancelled: %s, %zu result(s): %s\n", client.getState().toString().c_str(), result->results.size(),
              result->message.c_str());
  EXPECT_EQ(client.getState(), actionlib::SimpleClientGoalState::PREEMPTED);
  EXPECT_LT(result->results.size(), 3u);
  EXPECT_NE(result->message.find("cancelled before"), std::string::npos) << result->message;
}

// The service beside the action: the same work, all cameras, no feedback.
TEST(CalibrationNodeAsync, ServiceStillCalibrates)
{
  ic::Calibrate srv;
  srv.request.camera = "cam_east";
  ASSERT_TRUE(ros::service::call("/calibration_node/calibrate", srv));
  std::printf("service: %s\n", srv.response.message.c_str());
  ASSERT_EQ(srv.response.results.size(), 1u);
  // The answer carries the sigma as saved (in the map frame) and its parts.
  EXPECT_NE(srv.response.message.find("1 sigma in the map frame (as saved)"), std::string::npos)
      << srv.response.message;
  EXPECT_NE(srv.response.message.find("map placement"), std::string::npos) << srv.response.message;
  EXPECT_TRUE(srv.response.success) << srv.response.message;
}

// /diagnostics per camera and for the survey, and the latched ~survey_status, after the calibrations above.
TEST(CalibrationNodeAsync, DiagnosticsAndSurveyStatus)
{
  ros::WallDuration(2.5).sleep();  // a diagnostics period after the last calibration
  for (const char* camera : {"cam_east", "cam_wide", "cam_desk"})
  {
    const auto status = diagnostics(std::string("calibration_node: camera ") + camera);
    ASSERT_TRUE(status) << "no diagnostics for " << camera;
    std::printf("diagnostics %s: level %d, %s\n", camera, status->level, status->message.c_str());
    // Calibrated; the bag has ended, so its images are stale (older than 10 s) or about to be.
    EXPECT_TRUE(status->message == "calibrated" || status->message.rfind("stale images", 0) == 0) << status->message;
    EXPECT_NE(status->level, diagnostic_msgs::DiagnosticStatus::ERROR);
    // The saved sigma's parts (uncertainty_budget.h), also what a "too uncertain" WARN names.
    const auto parts = std::find_if(status->values.begin(), status->values.end(),
                                    [](const auto& v) { return v.key == "sigma parts (position / rotation)"; });
    ASSERT_NE(parts, status->values.end()) << camera;
    EXPECT_NE(parts->value.find("matched lines"), std::string::npos) << parts->value;
    EXPECT_NE(parts->value.find("map placement"), std::string::npos) << parts->value;
  }
  const auto survey = diagnostics("calibration_node: survey");
  ASSERT_TRUE(survey);
  EXPECT_EQ(survey->message, "every camera calibrated");
  // config/cameras.yaml gives no depth registration: the node uses 0,0 and estimates it by default.
  const auto registration = std::find_if(survey->values.begin(), survey->values.end(),
                                         [](const auto& v) { return v.key == "depth registration"; });
  ASSERT_NE(registration, survey->values.end());
  std::printf("depth registration: %s\n", registration->value.c_str());
  EXPECT_EQ(registration->value.rfind("in use 0.000, 0.000 px (default", 0), 0u) << registration->value;
  // The bag's 80 keyframes give 11 creases, 10 needed: an estimate, or else the estimator's reason.
  EXPECT_TRUE(registration->value.find("; estimated ") != std::string::npos ||
              registration->value.find("; depth registration: ") != std::string::npos)
      << registration->value;
  std::lock_guard<std::mutex> lock(g_mutex);
  ASSERT_TRUE(g_survey_status) << "nothing on the latched ~survey_status";
  EXPECT_EQ(g_survey_status->cameras.size(), 3u);
  EXPECT_GT(g_survey_status->map_lines_used, 0u);
  for (const auto& camera : g_survey_status->cameras)
    EXPECT_TRUE(camera.calibrated) << camera.camera_name;
  std::printf("survey status: %s\n", g_survey_status->message.c_str());
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_calibration_async");
  ros::NodeHandle private_nh("~");
  private_nh.getParam("bag_start", g_bag_start);
  private_nh.getParam("bag_end", g_bag_end);
  ros::NodeHandle nh;
  ros::Subscriber diagnostics_subscriber = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, boost::function<void(const diagnostic_msgs::DiagnosticArrayConstPtr&)>([](const auto& array) {
        std::lock_guard<std::mutex> lock(g_mutex);
        for (const auto& status : array->status)
          g_diagnostics[status.name] = status;
      }));
  ros::Subscriber survey_subscriber = nh.subscribe<ic::SurveyStatus>(
      "/calibration_node/survey_status", 1,
      boost::function<void(const ic::SurveyStatusConstPtr&)>([](const ic::SurveyStatusConstPtr& msg) {
        std::lock_guard<std::mutex> lock(g_mutex);
        g_survey_status = msg;
      }));
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
