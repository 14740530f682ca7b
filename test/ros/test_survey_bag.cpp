// The survey bag as the calibration node will see it (no ROS master needed): exactly the expected topics, openni2's
// encodings, frames and camera_info, the same bytes for the same seed, depth that back-projects onto the world's
// surfaces through the *recorded* tf, ground-truth files beside the bag, and the command line's errors.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2/buffer_core.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/ros/survey_bag_writer.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/true_edges.h"

namespace fs = std::filesystem;
namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const std::string kWorld = std::string(INSITU_SOURCE_DIR) + "/config/worlds/waiting_room.yaml";
const std::string kTool = std::string(INSITU_TOOL_DIR) + "/simulate_survey";

fs::path tempDir()
{
  const fs::path dir = fs::temp_directory_path() / ("insitu_survey_bag_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

// Runs a command, returns its exit status and its standard output and error.
int run(const std::string& command, std::string* output)
{
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe)
    return -1;
  std::array<char, 4096> buffer;
  output->clear();
  size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0)
    output->append(buffer.data(), n);
  const int status = ::pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string simulate(const std::string& bag, int seed, const std::string& extra = "")
{
  std::string out;
  const int status = run(kTool + " --world " + kWorld + " --out " + bag + " --seed " + std::to_string(seed) +
                             " --duration 3 --fixed-rate 1 --quiet " + extra,
                         &out);
  EXPECT_EQ(status, 0) << out;
  return out;
}

std::string fileBytes(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

const std::vector<std::string> kExpectedTopics = {
    "/camera/depth_registered/camera_info",
    "/camera/depth_registered/image_raw",
    "/camera/rgb/camera_info",
    "/camera/rgb/image_raw",
    "/fixed/cam_desk/camera_info",
    "/fixed/cam_desk/image_raw",
    "/fixed/cam_east/camera_info",
    "/fixed/cam_east/image_raw",
    "/fixed/cam_wide/camera_info",
    "/fixed/cam_wide/image_raw",
    "/tf",
    "/tf_static",
};

class SurveyBag : public ::testing::Test
{
protected:
  static void SetUpTestSuite()
  {
    dir_ = tempDir();
    simulate((dir_ / "a.bag").string(), 11);
    simulate((dir_ / "b.bag").string(), 11);
    simulate((dir_ / "c.bag").string(), 12);
    simulate((dir_ / "exact.bag").string(), 11, "--no-depth-noise");
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static fs::path dir_;
};
fs::path SurveyBag::dir_;
}  // namespace

TEST_F(SurveyBag, RosbagInfoListsExactlyTheTopics)
{
  std::string out;
  ASSERT_EQ(run("rosbag info --yaml --key=topics " + (dir_ / "a.bag").string(), &out), 0) << out;
  std::vector<std::string> topics;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);)
    if (const auto at = line.find("topic: "); at != std::string::npos)
      topics.push_back(line.substr(at + 7));
  std::sort(topics.begin(), topics.end());
  EXPECT_EQ(topics, kExpectedTopics);
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world);
  EXPECT_EQ(ic::surveyTopics(*world), kExpectedTopics);
  ASSERT_EQ(run("rosbag info --yaml --key=compression " + (dir_ / "a.bag").string(), &out), 0);
  EXPECT_NE(out.find("lz4"), std::string::npos) << out;
}

TEST_F(SurveyBag, SameSeedSameBag)
{
  const std::string a = fileBytes((dir_ / "a.bag").string());
  EXPECT_GT(a.size(), 1000000u);
  EXPECT_TRUE(a == fileBytes((dir_ / "b.bag").string())) << "two runs with one seed differ";
  // Message by message: identical for one seed; another seed changes the noisy images only.
  rosbag::Bag bag_a((dir_ / "a.bag").string()), bag_c((dir_ / "c.bag").string());
  rosbag::View view_a(bag_a), view_c(bag_c);
  ASSERT_EQ(view_a.size(), view_c.size());
  std::set<std::string> differing;
  for (auto ia = view_a.begin(), ic_ = view_c.begin(); ia != view_a.end(); ++ia, ++ic_)
  {
    ASSERT_EQ(ia->getTopic(), ic_->getTopic());
    ASSERT_EQ(ia->getTime(), ic_->getTime());
    std::vector<uint8_t> ba(ia->size()), bc(ic_->size());
    ros::serialization::OStream sa(ba.data(), ba.size()), sc(bc.data(), bc.size());
    ia->write(sa);
    ic_->write(sc);
    if (ba != bc)
      differing.insert(ia->getTopic());
  }
  EXPECT_EQ(differing, (std::set<std::string>{"/camera/depth_registered/image_raw", "/fixed/cam_desk/image_raw",
                                              "/fixed/cam_east/image_raw", "/fixed/cam_wide/image_raw"}));
}

namespace
{
// An image: the Xtion's as openni2_launch publishes them, a fixed camera's as a network camera driver does.
void expectImageLike(const sensor_msgs::Image& image, const std::string& topic, const sim::World& world)
{
  if (topic == "/camera/rgb/image_raw" || topic == "/camera/depth_registered/image_raw")
  {
    EXPECT_EQ(image.header.frame_id, "camera_rgb_optical_frame");
    EXPECT_EQ(image.width, 640u);
    EXPECT_EQ(image.height, 480u);
    EXPECT_EQ(image.encoding, topic == "/camera/rgb/image_raw" ? "rgb8" : "16UC1");
    EXPECT_EQ(image.step, topic == "/camera/rgb/image_raw" ? 1920u : 1280u);
    return;
  }
  const std::string name = topic.substr(7, topic.size() - 7 - 10);  // /fixed/<name>/image_raw
  const auto it = std::find_if(world.fixed_cameras.begin(), world.fixed_cameras.end(),
                               [&](const sim::SimulatedFixedCamera& c) { return c.name == name; });
  ASSERT_NE(it, world.fixed_cameras.end()) << topic;
  EXPECT_EQ(image.header.frame_id, name + "_optical_frame");
  EXPECT_EQ(static_cast<int>(image.width), it->width);
  EXPECT_EQ(static_cast<int>(image.height), it->height);
  EXPECT_EQ(image.encoding, "rgb8");
}

// A camera_info: the Xtion's factory intrinsics, or only the nominal size for an uncalibrated network camera.
void expectCameraInfoLike(const sensor_msgs::CameraInfo& info, const std::string& topic, const sim::World& world)
{
  if (topic.rfind("/camera/", 0) == 0)
  {
    EXPECT_EQ(info.header.frame_id, "camera_rgb_optical_frame");
    EXPECT_EQ(info.distortion_model, "plumb_bob");
    EXPECT_EQ(info.D, std::vector<double>(5, 0.0));
    EXPECT_DOUBLE_EQ(info.K[0], world.xtion.intrinsics.fx);
    EXPECT_DOUBLE_EQ(info.K[4], world.xtion.intrinsics.fy);
    EXPECT_DOUBLE_EQ(info.K[2], 319.5);
    EXPECT_DOUBLE_EQ(info.P[0], world.xtion.intrinsics.fx);
    return;
  }
  EXPECT_GT(info.width, 0u);
  EXPECT_GT(info.height, 0u);
  EXPECT_TRUE(info.distortion_model.empty());
  EXPECT_TRUE(info.D.empty());
  for (double k : info.K)
    EXPECT_EQ(k, 0.0);
  for (double p : info.P)
    EXPECT_EQ(p, 0.0);
}

// /tf_static: the Xtion's frames, latched; /tf: map -> odom -> base_link.
void expectTransformsLike(const rosbag::MessageInstance& m)
{
  const auto tf = m.instantiate<tf2_msgs::TFMessage>();
  ASSERT_TRUE(tf);
  if (m.getTopic() == "/tf_static")
  {
    std::set<std::string> pairs;
    for (const auto& t : tf->transforms)
      pairs.insert(t.header.frame_id + ">" + t.child_frame_id);
    EXPECT_EQ(pairs,
              (std::set<std::string>{"base_link>camera_link", "camera_link>camera_rgb_frame",
                                     "camera_rgb_frame>camera_rgb_optical_frame", "camera_link>camera_depth_frame",
                                     "camera_depth_frame>camera_depth_optical_frame"}));
    EXPECT_EQ(m.getConnectionHeader()->at("latching"), "1");
    return;
  }
  ASSERT_EQ(tf->transforms.size(), 2u);
  EXPECT_EQ(tf->transforms[0].header.frame_id, "map");
  EXPECT_EQ(tf->transforms[0].child_frame_id, "odom");
  EXPECT_EQ(tf->transforms[1].header.frame_id, "odom");
  EXPECT_EQ(tf->transforms[1].child_frame_id, "base_link");
}
}  // namespace

TEST_F(SurveyBag, MessagesLookLikeOpenni2AndNetworkCameras)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world);
  rosbag::Bag bag((dir_ / "a.bag").string());
  std::map<std::string, size_t> count;
  for (const rosbag::MessageInstance& m : rosbag::View(bag))
  {
    const std::string& topic = m.getTopic();
    ++count[topic];
    if (const auto image = m.instantiate<sensor_msgs::Image>())
    {
      EXPECT_EQ(image->header.stamp, m.getTime());
      expectImageLike(*image, topic, *world);
    }
    if (const auto info = m.instantiate<sensor_msgs::CameraInfo>())
    {
      EXPECT_EQ(info->header.stamp, m.getTime());
      expectCameraInfoLike(*info, topic, *world);
    }
    if (topic == "/tf_static" || topic == "/tf")
      expectTransformsLike(m);
  }
  // 3 s: RGB-D at 5 Hz, tf at 20 Hz (0 .. 3 s inclusive), fixed cameras at 1 Hz.
  EXPECT_EQ(count["/camera/rgb/image_raw"], 15u);
  EXPECT_EQ(count["/camera/depth_registered/camera_info"], 15u);
  EXPECT_EQ(count["/tf"], 61u);
  EXPECT_EQ(count["/tf_static"], 1u);
  EXPECT_EQ(count["/fixed/cam_wide/image_raw"], 3u);
}

// Depth back-projected with the camera_info intrinsics and the bag's own /tf and /tf_static lands on the world's
// surfaces (exact depth: median under 1 mm).
TEST_F(SurveyBag, DepthThroughRecordedTfLandsOnSurfaces)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world);
  rosbag::Bag bag((dir_ / "exact.bag").string());
  tf2::BufferCore buffer(ros::Duration(100.0));
  std::vector<sensor_msgs::Image::ConstPtr> depths;
  sensor_msgs::CameraInfo::ConstPtr info;
  for (const rosbag::MessageInstance& m : rosbag::View(bag))
  {
    if (m.getTopic() == "/tf" || m.getTopic() == "/tf_static")
    {
      const tf2_msgs::TFMessage::ConstPtr tf = m.instantiate<tf2_msgs::TFMessage>();
      for (const auto& t : tf->transforms)
        buffer.setTransform(t, "bag", m.getTopic() == "/tf_static");
    }
    else if (m.getTopic() == "/camera/depth_registered/image_raw")
      depths.push_back(m.instantiate<sensor_msgs::Image>());
    else if (m.getTopic() == "/camera/depth_registered/camera_info")
      info = m.instantiate<sensor_msgs::CameraInfo>();
  }
  ASSERT_TRUE(info);
  ASSERT_EQ(depths.size(), 15u);
  std::vector<double> errors;
  for (const auto& depth : depths)
  {
    const Eigen::Isometry3d map_from_optical =
        tf2::transformToEigen(buffer.lookupTransform("map", depth->header.frame_id, depth->header.stamp));
    const uint16_t* data = reinterpret_cast<const uint16_t*>(depth->data.data());
    for (uint32_t y = 3; y < depth->height; y += 16)
      for (uint32_t x = 5; x < depth->width; x += 16)
      {
        const uint16_t mm = data[y * depth->width + x];
        if (mm == 0)
          continue;
        const double z = mm * 1e-3;
        const Eigen::Vector3d p =
            map_from_optical * Eigen::Vector3d(z * (x - info->K[2]) / info->K[0], z * (y - info->K[5]) / info->K[4], z);
        double d = 1e9;
        for (const auto& s : world->surfaces)
          d = std::min(d, s.distance(p));
        errors.push_back(d);
      }
  }
  ASSERT_GT(errors.size(), 3000u);
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  const double median = errors[errors.size() / 2];
  std::printf("depth through the recorded tf: %zu points, median distance to the surfaces %.3f mm\n", errors.size(),
              1e3 * median);
  EXPECT_LT(median, 1e-3);
}

TEST_F(SurveyBag, GroundTruthBesideTheBag)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world);
  const fs::path truth = dir_ / "a_truth";
  for (const auto& c : world->fixed_cameras)
  {
    const auto calibration = ic::loadCalibrationFile((truth / (c.name + ".yaml")).string());
    ASSERT_TRUE(calibration) << calibration.error().describe();
    EXPECT_EQ(calibration->camera_name, c.name);
    EXPECT_EQ(calibration->image_width, c.width);
    EXPECT_NEAR(calibration->camera.distortion().lambda, c.camera.distortion().lambda, 1e-20);
    const ic::Matrix34d a = calibration->camera.projectionMatrix(), b = c.camera.projectionMatrix();
    EXPECT_LT((a / a.norm() - b / b.norm()).norm(), 1e-9);
    EXPECT_LT((calibration->camera.pose().center() - c.camera.pose().center()).norm(), 1e-9);
  }
  const auto edges = sim::loadTrueEdges((truth / "edges.yaml").string());
  ASSERT_TRUE(edges) << edges.error().describe();
  EXPECT_EQ(edges->size(), sim::computeTrueEdges(*world).size());
  EXPECT_TRUE(fs::exists(truth / "survey.yaml"));
}

TEST(SimulateSurveyTool, AnswersHelpAndRefusesBadInput)
{
  std::string out;
  EXPECT_EQ(run(kTool + " --help", &out), 0);
  EXPECT_NE(out.find("Usage: simulate_survey --world"), std::string::npos);
  EXPECT_EQ(run(kTool + " --world " + kWorld + " --out /tmp/x.bag", &out), 2);  // no seed
  EXPECT_NE(out.find("--seed"), std::string::npos) << out;
  EXPECT_EQ(run(kTool + " --world " + kWorld + " --out /tmp/x.bag --seed 1 --duration -3", &out), 2);
  EXPECT_NE(out.find("duration"), std::string::npos) << out;
  const fs::path bad = tempDir() / "bad_world.yaml";
  std::ofstream(bad) << "surfaces: [{name: floor, polygon: [[0, 0, 0], [1, 0, 0]]}]\nroute: {waypoints: [[0, 0], [1, "
                        "0]]}\nfixed_cameras: []\n";
  EXPECT_EQ(run(kTool + " --world " + bad.string() + " --out /tmp/x.bag --seed 1", &out), 2);
  EXPECT_NE(out.find("bad_world.yaml: surfaces[0] 'floor': polygon has 2 vertices, at least 3 are needed"),
            std::string::npos)
      << out;
  EXPECT_FALSE(fs::exists("/tmp/x.bag"));
  EXPECT_EQ(run(kTool + " --world " + kWorld + " --out /nonexistent_dir/x.bag --seed 1 --duration 1", &out), 1);
  EXPECT_NE(out.find("cannot write"), std::string::npos) << out;
  // A disk that fills while the bag is written (a 1 MB file size limit, its signal ignored so that writes fail):
  // a clear error, no crash, nothing left behind (rosbag's destructor used to throw and abort the program).
  const fs::path full = tempDir() / "full.bag";
  EXPECT_EQ(run("bash -c \"ulimit -f 1024; trap '' XFSZ; exec " + kTool + " --world " + kWorld + " --out " +
                    full.string() + " --seed 1 --duration 2 --quiet\"",
                &out),
            1);
  EXPECT_NE(out.find("cannot write " + full.string()), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(full));
  EXPECT_FALSE(fs::exists(full.string() + ".active"));
  fs::remove_all(tempDir());
}
