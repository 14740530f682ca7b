// calibration_node's parameters are validated like any input (calibration_parameters.test, issue 16): a negative
// rate, a NaN sigma, a string where a number is due, and several bad parameters at once each make the node exit
// with status 1 at start-up, with a FATAL message naming the parameter, its value and the allowed range.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <ros/ros.h>

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
}  // namespace

TEST(CalibrationNodeParameters, NegativeRateIsFatal)
{
  const Outcome outcome = runNode("negative_rate");
  EXPECT_EQ(outcome.exit_status, 1) << outcome.output;
  EXPECT_NE(outcome.output.find("parameter ~status_period is -1, allowed: a number in [0, 86400] s"), std::string::npos)
      << outcome.output;
}

TEST(CalibrationNodeParameters, NanSigmaIsFatal)
{
  const Outcome outcome = runNode("nan_sigma");
  EXPECT_EQ(outcome.exit_status, 1) << outcome.output;
  EXPECT_NE(outcome.output.find("parameter ~localization_sigma_m is nan, allowed: a number in [0, 10] m"),
            std::string::npos)
      << outcome.output;
}

TEST(CalibrationNodeParameters, StringForNumberIsFatal)
{
  const Outcome outcome = runNode("string_number");
  EXPECT_EQ(outcome.exit_status, 1) << outcome.output;
  EXPECT_NE(outcome.output.find("parameter ~tf_timeout is the string 'fast', allowed: a number in [0, 60] s"),
            std::string::npos)
      << outcome.output;
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

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_calibration_parameters");
  ros::param::get("/work_dir", g_work_dir);
  std::filesystem::create_directories(g_work_dir);
  return RUN_ALL_TESTS();
}
