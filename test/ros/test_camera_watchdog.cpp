// The moved-camera watchdog end to end (camera_watchdog.test): calibration_node.test's survey bag plays into the
// node (cam_east only), the test calibrates cam_east, then publishes images of cam_east rendered by the simulator
// from the same world: unmoved (several ~verify calls and periodic checks: never flagged), rotated by 1 degree and
// translated by 5 cm in its optical frame (~verify says moved, with the rotation, translation and image displacement
// within 3 of their sigmas of the truth, /diagnostics warns), and finally recalibrates the translated camera: the
// reply says how far it moved and the previous YAML is kept beside the new one. The truth of the displacement is
// computed at the node's own map lines (its ~markers) with the saved calibration moved by the true motion.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <mutex>

#include <cv_bridge/cv_bridge.h>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include "insitu_calibration/Calibrate.h"
#include "insitu_calibration/CalibrationStatus.h"
#include "insitu_calibration/Verify.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/survey/camera_verification.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;
namespace fs = std::filesystem;

namespace
{
const std::string kCamera = "cam_east";
std::string g_work_dir;
double g_bag_end = 0.0;
double g_next_stamp = 0.0;  // images published by the test: after the bag, 0.6 s apart (the node keeps one per 0.5 s)

std::mutex g_mutex;
std::vector<ic::Segment3d> g_map;            // the node's line map, from its ~markers
std::vector<std::string> g_camera_warnings;  // /diagnostics WARN messages of cam_east about a moved camera

void markersCallback(const visualization_msgs::MarkerArray& markers)
{
  std::lock_guard<std::mutex> lock(g_mutex);
  for (const auto& m : markers.markers)
    if (m.ns == "line_map" && m.points.size() >= 2)
    {
      g_map.clear();
      for (size_t i = 0; i + 1 < m.points.size(); i += 2)
        g_map.push_back(
            {{m.points[i].x, m.points[i].y, m.points[i].z}, {m.points[i + 1].x, m.points[i + 1].y, m.points[i + 1].z}});
    }
}

void diagnosticsCallback(const diagnostic_msgs::DiagnosticArray& array)
{
  std::lock_guard<std::mutex> lock(g_mutex);
  for (const auto& status : array.status)
    if (status.name.find("camera " + kCamera) != std::string::npos &&
        status.level == diagnostic_msgs::DiagnosticStatus::WARN && status.message.find("moved") != std::string::npos)
      g_camera_warnings.push_back(status.message);
}

int cameraIndex(const sim::World& world)
{
  for (size_t c = 0; c < world.fixed_cameras.size(); ++c)
    if (world.fixed_cameras[c].name == kCamera)
      return static_cast<int>(c);
  return -1;
}

// A simulator of the world with cam_east moved by `motion` (its optical frame): its clean image is rendered once,
// each frame gets fresh sensor noise.
struct MovedCamera
{
  MovedCamera(const Eigen::Isometry3d& motion, uint64_t seed)
  {
    auto world = sim::loadWorldFile(std::string(INSITU_SOURCE_DIR) + "/config/worlds/waiting_room.yaml");
    EXPECT_TRUE(world) << world.error().describe();
    camera = cameraIndex(*world);
    ic::CameraModel& model = world->fixed_cameras[camera].camera;
    model.pose() = ic::CameraPose::fromWorldFromCamera(model.pose().worldFromCamera() * motion);
    sim::SimulationOptions options;
    options.seed = seed;
    options.duration_s = 1.0;
    options.fixed_rate_hz = 20.0;  // 20 frames of the camera in the simulated second
    auto created = sim::SurveySimulator::create(*world, options);
    EXPECT_TRUE(created) << created.error().describe();
    simulator = std::make_unique<sim::SurveySimulator>(std::move(*created));
  }

  // Publishes `count` frames from frame `first` on, 0.3 s apart (the node's queue holds two images).
  void publish(image_transport::Publisher& publisher, int first, int count) const
  {
    for (int i = first; i < first + count; ++i)
    {
      std_msgs::Header header;
      header.stamp = ros::Time(g_next_stamp);
      header.frame_id = kCamera + "_optical_frame";
      g_next_stamp += 0.6;
      publisher.publish(cv_bridge::CvImage(header, "rgb8", simulator->fixedFrame(camera, i).image).toImageMsg());
      ros::WallDuration(0.3).sleep();
    }
    ros::WallDuration(0.5).sleep();
  }

  int camera = -1;
  std::unique_ptr<sim::SurveySimulator> simulator;
};

ic::Verify::Response verify()
{
  ic::Verify srv;
  srv.request.camera = kCamera;
  EXPECT_TRUE(ros::service::call("/calibration_node/verify", srv)) << "the service call itself failed";
  std::printf("verify: %s (success %d, moved %s)\n", srv.response.message.c_str(), srv.response.success,
              srv.response.moved.c_str());
  return srv.response;
}

ic::CalibrationFile savedCalibration()
{
  const auto file = ic::loadCalibrationFile(g_work_dir + "/" + kCamera + ".yaml");
  EXPECT_TRUE(file) << file.error().describe();
  return file ? *file : ic::CalibrationFile{};
}

// The truth of a motion as the watchdog measures it: the saved calibration moved by it, at the node's map lines.
ic::PoseDifference truthOf(const Eigen::Isometry3d& motion)
{
  const ic::CalibrationFile calibration = savedCalibration();
  std::vector<ic::Segment3d> map;
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(5.0);  // ~markers come every 2 s
  while (map.empty() && ros::WallTime::now() < deadline)
  {
    {
      std::lock_guard<std::mutex> lock(g_mutex);
      map = g_map;
    }
    ros::WallDuration(0.1).sleep();
  }
  EXPECT_FALSE(map.empty()) << "no line map on ~markers";
  const ic::CameraPose after =
      ic::CameraPose::fromWorldFromCamera(calibration.camera.pose().worldFromCamera() * motion);
  return ic::poseDifference(
      calibration.camera, after,
      ic::visibleMapPoints(calibration.camera, calibration.image_width, calibration.image_height, map));
}

void expectMovedAsTruth(const ic::Verify::Response& r, const Eigen::Isometry3d& motion)
{
  const ic::PoseDifference truth = truthOf(motion);
  std::printf("truth: %.2f px / %.3f deg / %.1f mm\n", truth.displacement_px, truth.rotation_deg,
              1000.0 * truth.translation_m);
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.moved, "yes") << r.message;
  EXPECT_LT(std::abs(r.displacement_px - truth.displacement_px), 3.0 * r.displacement_sigma_px) << r.message;
  EXPECT_LT(std::abs(r.rotation_deg - truth.rotation_deg), 3.0 * r.rotation_sigma_deg) << r.message;
  EXPECT_LT(std::abs(r.translation_m - truth.translation_m), 3.0 * r.translation_sigma_m) << r.message;
}

Eigen::Isometry3d rotated()
{
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = Eigen::AngleAxisd(M_PI / 180.0, Eigen::Vector3d(1.0, 0.5, 0.3).normalized()).toRotationMatrix();
  return m;
}

Eigen::Isometry3d translated()
{
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.translation() = 0.05 * Eigen::Vector3d(-0.3, 0.8, 0.5).normalized();
  return m;
}
}  // namespace

TEST(CameraWatchdog, MovedCamerasAreDetectedAndUnmovedOnesNot)
{
  ros::NodeHandle nh;
  image_transport::ImageTransport it(nh);
  image_transport::Publisher images = it.advertise("/fixed/" + kCamera + "/image_raw", 2);
  const ros::Subscriber markers = nh.subscribe("/calibration_node/markers", 1, markersCallback);
  const ros::Subscriber diagnostics = nh.subscribe("/diagnostics", 20, diagnosticsCallback);
  ASSERT_TRUE(ros::service::waitForService("/calibration_node/verify", ros::Duration(60.0)));
  const auto early = verify();
  EXPECT_FALSE(early.success);
  EXPECT_NE(early.message.find("not calibrated"), std::string::npos) << early.message;

  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(120.0);
  while (ros::ok() && ros::Time::now().toSec() < g_bag_end - 0.5 && ros::WallTime::now() < deadline)
    ros::WallDuration(0.5).sleep();
  ASSERT_GE(ros::Time::now().toSec(), g_bag_end - 0.5) << "the bag did not finish playing";
  g_next_stamp = g_bag_end + 1.0;
  ic::Calibrate calibrate;
  calibrate.request.camera = kCamera;
  ASSERT_TRUE(ros::service::call("/calibration_node/calibrate", calibrate));
  ASSERT_TRUE(calibrate.response.success) << calibrate.response.message;
  EXPECT_FALSE(calibrate.response.results.at(0).had_previous);

  // Unmoved: ~verify after each new batch of images, and the periodic checks in between: never flagged.
  const MovedCamera unmoved(Eigen::Isometry3d::Identity(), 11);
  for (int batch = 0; batch < 3; ++batch)
  {
    unmoved.publish(images, 2 * batch, 2);
    const auto r = verify();
    ASSERT_TRUE(r.success) << r.message;
    EXPECT_EQ(r.moved, "no") << r.message;
  }
  ic::CalibrationStatus status;
  status.request.camera = kCamera;
  ASSERT_TRUE(ros::service::call("/calibration_node/status", status));
  ASSERT_EQ(status.response.cameras.size(), 1u);
  EXPECT_EQ(status.response.cameras[0].motion, "unmoved") << status.response.cameras[0].motion_message;
  {
    std::lock_guard<std::mutex> lock(g_mutex);
    EXPECT_TRUE(g_camera_warnings.empty()) << g_camera_warnings.front();
  }

  MovedCamera(rotated(), 21).publish(images, 0, 7);
  expectMovedAsTruth(verify(), rotated());
  const ros::WallTime diagnostics_deadline = ros::WallTime::now() + ros::WallDuration(3.0);  // updated every 1 s
  while (ros::WallTime::now() < diagnostics_deadline)
  {
    {
      std::lock_guard<std::mutex> lock(g_mutex);
      if (!g_camera_warnings.empty())
        break;
    }
    ros::WallDuration(0.1).sleep();
  }
  {
    std::lock_guard<std::mutex> lock(g_mutex);
    ASSERT_FALSE(g_camera_warnings.empty());
    EXPECT_NE(g_camera_warnings.back().find("camera moved by"), std::string::npos) << g_camera_warnings.back();
    EXPECT_NE(g_camera_warnings.back().find("recalibrate"), std::string::npos) << g_camera_warnings.back();
  }

  MovedCamera(translated(), 31).publish(images, 0, 7);
  expectMovedAsTruth(verify(), translated());

  // A recalibration of the translated camera: kept, and how far it moved.
  const std::string before = savedCalibration().camera_name;
  ASSERT_TRUE(ros::service::call("/calibration_node/calibrate", calibrate));
  ASSERT_TRUE(calibrate.response.success) << calibrate.response.message;
  std::printf("recalibrated: %s\n", calibrate.response.message.c_str());
  const auto& result = calibrate.response.results.at(0);
  EXPECT_TRUE(result.had_previous);
  EXPECT_NEAR(result.moved_translation_m, 0.05, 0.02) << result.message;
  EXPECT_LT(result.moved_rotation_deg, 0.3) << result.message;
  ASSERT_FALSE(result.previous_kept_as.empty()) << result.message;
  EXPECT_TRUE(fs::exists(result.previous_kept_as));
  EXPECT_EQ(fs::path(result.previous_kept_as).parent_path(), fs::path(g_work_dir));
  EXPECT_EQ(before, kCamera);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_camera_watchdog");
  ros::NodeHandle private_nh("~");
  private_nh.getParam("work_dir", g_work_dir);
  private_nh.getParam("bag_end", g_bag_end);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
