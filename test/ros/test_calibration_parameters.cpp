// calibration_node's parameters are validated like any input (calibration_parameters.test, issue 16): a negative
// rate, a NaN sigma, a string where a number is due, and several bad parameters at once each make the node exit
// with status 1 at start-up, with a FATAL message naming the parameter, its value and the allowed range.
// The field-tuned thresholds change at runtime through dynamic_reconfigure (issue 14): the node's descriptions
// (cfg/Calibration.cfg) agree with field_thresholds.h, a launch value wins over the .cfg's default, a new max_rms_px
// changes what a calibration accepts, and a value out of range is refused with a warning.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <dynamic_reconfigure/ConfigDescription.h>
#include <dynamic_reconfigure/client.h>
#include <ros/ros.h>

#include "insitu_calibration/Calibrate.h"
#include "insitu_calibration/CalibrationConfig.h"
#include "insitu_calibration/survey/field_thresholds.h"
#include "node_process.h"

namespace
{
std::string g_work_dir;

struct Outcome
{
  int exit_status = -1;
  std::string output;
};

// The node started under the namespace (its parameters are set by the .test file), until it exits (20 s at most).
Outcome runNode(const std::string& name)
{
  const std::string log = g_work_dir + "/" + name + ".log";
  Outcome outcome;
  {
    NodeProcess node(name, log);
    EXPECT_TRUE(node.started());
    outcome.exit_status = node.waitForExit(20.0);
  }  // a node still running is stopped here
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  outcome.output = text.str();
  return outcome;
}

// The node started under `name` exits with status 1 and its output says `message`.
void expectFatal(const std::string& name, const std::string& message)
{
  const Outcome outcome = runNode(name);
  EXPECT_EQ(outcome.exit_status, 1) << outcome.output;
  EXPECT_NE(outcome.output.find(message), std::string::npos) << message << "\n" << outcome.output;
}
}  // namespace

TEST(CalibrationNodeParameters, NegativeRateIsFatal)
{
  expectFatal("negative_rate", "parameter ~status_period is -1, allowed: a number in [0, 86400] s");
}

TEST(CalibrationNodeParameters, NanSigmaIsFatal)
{
  expectFatal("nan_sigma", "parameter ~localization_sigma_m is nan, allowed: a number in [0, 10] m");
}

TEST(CalibrationNodeParameters, StringForNumberIsFatal)
{
  expectFatal("string_number", "parameter ~tf_timeout is the string 'fast', allowed: a number in [0, 60] s");
}

TEST(CalibrationNodeParameters, EveryBadParameterIsReported)
{
  const Outcome outcome = runNode("several");
  EXPECT_EQ(outcome.exit_status, 1) << outcome.output;
  for (const char* message :
       {"parameter ~median_images is 2.5, allowed: an integer in [1, 255]",
        "parameter ~diagnostics/max_sigma_rotation_deg is inf, allowed: a number in (0, 180] deg",
        "parameters ~min_focal_ratio (5) and ~max_focal_ratio (2): the minimum must be below the maximum",
        "parameter ~refine is the string 'yes', allowed: true or false",
        "parameter ~world_frame is the integer 7, allowed: a string"})
    EXPECT_NE(outcome.output.find(message), std::string::npos) << message << "\n" << outcome.output;
}

namespace ic = insitu_calibration;
namespace
{

std::string readFile(const std::string& path)
{
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A parameter's value in a dynamic_reconfigure Config message (doubles and ints); NaN when absent.
double valueIn(const dynamic_reconfigure::Config& config, const std::string& name)
{
  for (const auto& p : config.doubles)
    if (p.name == name)
      return p.value;
  for (const auto& p : config.ints)
    if (p.name == name)
      return p.value;
  return std::numeric_limits<double>::quiet_NaN();
}

template <typename Message>
boost::shared_ptr<const Message> waitForLatched(const std::string& topic)
{
  return ros::topic::waitForMessage<Message>(topic, ros::Duration(20.0));
}

ic::CalibrationResult calibrate(const std::string& camera)
{
  ic::Calibrate call;
  call.request.camera = camera;
  EXPECT_TRUE(ros::service::call("/reconfigure/calibrate", call));
  return call.response.results.empty() ? ic::CalibrationResult() : call.response.results.front();
}

// The node's descriptions (its .cfg) agree with the table: every threshold once, same type, default, min and max.
TEST(CalibrationNodeReconfigure, DescriptionsMatchTheThresholdTable)
{
  NodeProcess node("reconfigure", g_work_dir + "/reconfigure_descriptions.log");
  ASSERT_TRUE(node.started());
  const auto description =
      waitForLatched<dynamic_reconfigure::ConfigDescription>("/reconfigure/parameter_descriptions");
  ASSERT_TRUE(description) << readFile(g_work_dir + "/reconfigure_descriptions.log");
  const ic::FieldThresholds defaults;
  size_t described = 0;
  for (const auto& group : description->groups)
    described += group.parameters.size();
  EXPECT_EQ(described, ic::fieldThresholds().size());
  for (const ic::FieldThreshold& threshold : ic::fieldThresholds())
  {
    const std::string& name = threshold.reconfigure_name;
    const bool is_int = std::any_of(description->dflt.ints.begin(), description->dflt.ints.end(),
                                    [&](const auto& p) { return p.name == name; });
    EXPECT_EQ(is_int, threshold.range.integer) << name;
    EXPECT_EQ(valueIn(description->dflt, name), threshold.get(defaults)) << name;
    EXPECT_EQ(valueIn(description->min, name), threshold.range.min) << name;
    EXPECT_EQ(valueIn(description->max, name), threshold.range.max) << name;
  }
  // The launch file's value wins over the .cfg's default (0.2) at start-up.
  const auto state = waitForLatched<dynamic_reconfigure::Config>("/reconfigure/parameter_updates");
  ASSERT_TRUE(state);
  EXPECT_EQ(valueIn(*state, "watchdog_max_rotation_deg"), 0.3);
  EXPECT_EQ(valueIn(*state, "max_rms_px"), defaults.cameras.max_rms_px);
}

TEST(CalibrationNodeReconfigure, ThresholdsChangeAtRuntime)
{
  const std::string log = g_work_dir + "/reconfigure_runtime.log";
  NodeProcess node("reconfigure", log);
  ASSERT_TRUE(node.started());
  ASSERT_TRUE(ros::service::waitForService("/reconfigure/calibrate", ros::Duration(20.0)));
  dynamic_reconfigure::Client<ic::CalibrationConfig> client("/reconfigure");
  ic::CalibrationConfig config;
  ASSERT_TRUE(client.getCurrentConfiguration(config, ros::Duration(10.0)));

  // The example's correspondences calibrate within the default limit; below their RMS, the same calibration is
  // refused, and accepted again once the limit is back.
  const ic::CalibrationResult accepted = calibrate("lobby_cam");
  ASSERT_TRUE(accepted.success) << accepted.message;
  config.max_rms_px = 0.001;
  ASSERT_TRUE(client.setConfiguration(config));
  EXPECT_EQ(config.max_rms_px, 0.001);  // the reply: accepted
  const ic::CalibrationResult refused = calibrate("lobby_cam");
  EXPECT_FALSE(refused.success);
  EXPECT_NE(refused.message.find("above the limit of 0.001"), std::string::npos) << refused.message;
  double on_server = 0.0;
  EXPECT_TRUE(ros::param::get("/reconfigure/max_rms_px", on_server));
  EXPECT_EQ(on_server, 0.001);

  // Out of range: refused as a whole (the watchdog threshold in the same request too), with a warning.
  config.max_rms_px = 500.0;
  config.watchdog_max_displacement_px = 5.0;
  ASSERT_TRUE(client.setConfiguration(config));
  EXPECT_EQ(config.max_rms_px, 0.001);
  EXPECT_EQ(config.watchdog_max_displacement_px, 2.0);
  config.watchdog_max_displacement_px = 0.0;  // the range is (0, 1000]: 0 refused although the .cfg's min
  ASSERT_TRUE(client.setConfiguration(config));
  EXPECT_EQ(config.watchdog_max_displacement_px, 2.0);
  config.min_focal_ratio = 20.0;  // above max_focal_ratio (10)
  ASSERT_TRUE(client.setConfiguration(config));
  EXPECT_EQ(config.min_focal_ratio, 0.2);

  // A watchdog threshold alone, in range: accepted, and on the parameter server under its start-up name.
  config.watchdog_max_displacement_px = 5.0;
  ASSERT_TRUE(client.setConfiguration(config));
  EXPECT_EQ(config.watchdog_max_displacement_px, 5.0);
  EXPECT_TRUE(ros::param::get("/reconfigure/watchdog/max_displacement_px", on_server));
  EXPECT_EQ(on_server, 5.0);
  config.max_rms_px = 1.5;
  ASSERT_TRUE(client.setConfiguration(config));
  const ic::CalibrationResult again = calibrate("lobby_cam");
  EXPECT_TRUE(again.success) << again.message;
  EXPECT_NEAR(again.rms_px, accepted.rms_px, 1e-9);

  node.stop();
  const std::string output = readFile(log);
  for (const char* warning :
       {"dynamic_reconfigure refused: parameter ~max_rms_px is 500, allowed: a number in (0, 100] px",
        "dynamic_reconfigure refused: parameter ~watchdog_max_displacement_px is 0, allowed: a number in (0, 1000] px",
        "the minimum must be below the maximum", "dynparam set /reconfigure <parameter> <value>"})
    EXPECT_NE(output.find(warning), std::string::npos) << warning << "\n" << output;
}
}  // namespace

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_calibration_parameters");
  ros::param::get("/work_dir", g_work_dir);
  std::filesystem::create_directories(g_work_dir);
  ros::AsyncSpinner spinner(1);  // the dynamic_reconfigure client's subscriptions
  spinner.start();
  return RUN_ALL_TESTS();
}
