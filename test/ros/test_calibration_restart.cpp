// calibration_node restarted over hostile saved calibrations (calibration_restart.test, issue 16).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <std_srvs/Trigger.h>

#include "insitu_calibration/CalibrationStatus.h"
#include "insitu_calibration/io/calibration_file.h"
#include "node_process.h"

namespace ic = insitu_calibration;
namespace fs = std::filesystem;

namespace
{
std::string g_work_dir;

std::string readText(const fs::path& path)
{
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void writeText(const fs::path& path, const std::string& text)
{
  std::ofstream(path, std::ios::binary) << text;
}

std::string replaced(std::string text, const std::string& from, const std::string& to)
{
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

std::map<std::string, bool> calibratedCameras()
{
  std::map<std::string, bool> out;
  ic::CalibrationStatus status;
  if (!ros::service::call("/restart_node/status", status))
    return out;
  for (const auto& c : status.response.cameras)
    out[c.camera_name] = c.calibrated;
  return out;
}
}  // namespace

TEST(CalibrationRestart, BadSavedCalibrationsAreSetAsideAndNothingIsLost)
{
  const fs::path dir(g_work_dir);
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string good = readText(std::string(INSITU_SOURCE_DIR) + "/config/examples/lobby_cam_truth.yaml");
  ASSERT_TRUE(ic::parseCalibration(good));
  std::map<std::string, std::string> files = {
      {"good_cam.yaml", good},
      {"corrupt_cam.yaml", replaced(good, "division_model:\n", "division_model: 5\nrest:\n")},
      {"nan_cam.yaml", replaced(good, "lambda: -2.52940599848251e-08", "lambda: .nan")},
      {"zero_k_cam.yaml",
       replaced(good, "[1398.02936576119, 0, 617.187466866338, 0, 1422.21848150394, 509.442430927916, 0, 0, 1]",
                "[0, 0, 0, 0, 0, 0, 0, 0, 0]")}};
  for (const char* camera : {"good_cam", "corrupt_cam", "nan_cam", "zero_k_cam"})
    files[std::string(camera) + "_overlay.png"] = std::string("an overlay drawn before the restart: ") + camera;
  for (const auto& [name, text] : files)
    writeText(dir / name, text);
  // What a save killed between its write and its rename leaves.
  writeText(dir / "good_cam.yaml.tmp.a1B2c3", "image_width: 12");
  writeText(dir / "good_cam_overlay.png.tmp.Zz9Yy8", "");
  writeText(dir / ".good_cam_overlay.tmp.png", "");

  for (int start = 0; start < 2; ++start)
  {
    NodeProcess node;
    ASSERT_TRUE(node.started());
    ASSERT_TRUE(ros::service::waitForService("/restart_node/status", ros::Duration(60.0))) << "start " << start;
    const auto calibrated = calibratedCameras();
    ASSERT_EQ(calibrated.size(), 4u) << "start " << start;
    EXPECT_TRUE(calibrated.at("good_cam"));
    EXPECT_FALSE(calibrated.at("corrupt_cam"));
    EXPECT_FALSE(calibrated.at("nan_cam"));
    EXPECT_FALSE(calibrated.at("zero_k_cam"));

    // The valid calibration is republished (latched) with finite, positive focal lengths.
    const auto info = ros::topic::waitForMessage<sensor_msgs::CameraInfo>("/fixed/good_cam/camera_info_calibrated",
                                                                          ros::Duration(10.0));
    ASSERT_TRUE(info);
    EXPECT_NEAR(info->K[0], 1398.02936576119, 1e-6);
    EXPECT_GT(info->K[4], 0.0);

    std_srvs::Trigger save;
    ASSERT_TRUE(ros::service::call("/restart_node/save", save));
    EXPECT_TRUE(save.response.success) << save.response.message;
    EXPECT_EQ(node.stop(), 0) << "the node did not shut down cleanly";

    // The bad files are kept aside unchanged, each once (the second start finds none to move); the valid one and
    // every overlay are as they were; the temporaries are gone.
    EXPECT_EQ(readText(dir / "corrupt_cam.yaml.bad"), files["corrupt_cam.yaml"]);
    EXPECT_EQ(readText(dir / "nan_cam.yaml.bad"), files["nan_cam.yaml"]);
    EXPECT_EQ(readText(dir / "zero_k_cam.yaml.bad"), files["zero_k_cam.yaml"]);
    for (const char* gone :
         {"corrupt_cam.yaml", "nan_cam.yaml", "zero_k_cam.yaml", "corrupt_cam.yaml.bad.1", "good_cam.yaml.tmp.a1B2c3",
          "good_cam_overlay.png.tmp.Zz9Yy8", ".good_cam_overlay.tmp.png"})
      EXPECT_FALSE(fs::exists(dir / gone)) << gone;
    const auto reloaded = ic::loadCalibrationFile((dir / "good_cam.yaml").string());
    ASSERT_TRUE(reloaded) << reloaded.error().describe();
    EXPECT_NEAR(reloaded->camera.intrinsics().fx, 1398.02936576119, 1e-6);
    for (const char* camera : {"good_cam", "corrupt_cam", "nan_cam", "zero_k_cam"})
      EXPECT_EQ(readText(dir / (std::string(camera) + "_overlay.png")), files[std::string(camera) + "_overlay.png"])
          << camera;
  }
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_calibration_restart");
  ros::NodeHandle private_nh("~");
  private_nh.getParam("work_dir", g_work_dir);
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
