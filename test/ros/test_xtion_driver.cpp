// rostest of xtion_node (test/ros/xtion_driver.test): the launched node on OpenNI2's DummyDevice publishes every topic
// at the configured rate with the right encodings, sizes, frame ids and camera_info; and, with xtion_node processes
// this test starts itself: a recording made here from DummyDevice with OpenNI2's recorder plays back as the same
// frames; the end of a recording (a lost device) is reported and publishing resumes; a missing device and an
// unsupported mode give their message and retries without dying or spinning; SIGINT shuts the node down cleanly.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "insitu_calibration/drivers/openni_device.h"

namespace dr = insitu_calibration::drivers;
namespace fs = std::filesystem;

namespace
{
int g_fps = 30;
int g_width = 320;
int g_height = 240;

fs::path tempDir()
{
  const fs::path dir = fs::temp_directory_path() / ("insitu_xtion_rostest_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

uint64_t fnv(const uint8_t* data, size_t size, uint64_t hash = 1469598103934665603ull)
{
  for (size_t i = 0; i < size; ++i)
    hash = (hash ^ data[i]) * 1099511628211ull;
  return hash;
}

// Everything received on one image topic and its camera_info.
struct Received
{
  std::mutex mutex;
  std::vector<sensor_msgs::ImageConstPtr> images;
  std::vector<sensor_msgs::CameraInfoConstPtr> infos;
  std::vector<double> arrival;  // wall seconds
  std::vector<uint64_t> hashes;

  void onImage(const sensor_msgs::ImageConstPtr& image)
  {
    std::lock_guard<std::mutex> lock(mutex);
    images.push_back(image);
    arrival.push_back(ros::WallTime::now().toSec());
    hashes.push_back(fnv(image->data.data(), image->data.size()));
    if (images.size() > 400)  // keep memory bounded; the checks need only the recent frames
    {
      images.erase(images.begin());
      arrival.erase(arrival.begin());
    }
  }
  void onInfo(const sensor_msgs::CameraInfoConstPtr& info)
  {
    std::lock_guard<std::mutex> lock(mutex);
    infos.push_back(info);
    if (infos.size() > 400)
      infos.erase(infos.begin());
  }
  size_t count()
  {
    std::lock_guard<std::mutex> lock(mutex);
    return hashes.size();
  }
  void clear()
  {
    std::lock_guard<std::mutex> lock(mutex);
    images.clear();
    infos.clear();
    arrival.clear();
    hashes.clear();
  }
  // Messages a second over the arrivals after the first `skip`.
  double rate(size_t skip = 3)
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (arrival.size() < skip + 2)
      return 0.0;
    return (arrival.size() - 1 - skip) / (arrival.back() - arrival[skip]);
  }
};

struct CameraTopics
{
  Received rgb;
  Received depth;
  std::vector<ros::Subscriber> subscribers;

  explicit CameraTopics(const std::string& ns)
  {
    ros::NodeHandle nh;
    subscribers.push_back(nh.subscribe(ns + "/rgb/image_raw", 10, &Received::onImage, &rgb));
    subscribers.push_back(nh.subscribe(ns + "/rgb/camera_info", 10, &Received::onInfo, &rgb));
    subscribers.push_back(nh.subscribe(ns + "/depth_registered/image_raw", 10, &Received::onImage, &depth));
    subscribers.push_back(nh.subscribe(ns + "/depth_registered/camera_info", 10, &Received::onInfo, &depth));
  }
};

bool waitUntil(const std::function<bool()>& condition, double seconds)
{
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end)
  {
    if (condition())
      return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return condition();
}

std::string readFile(const std::string& path)
{
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

size_t occurrences(const std::string& text, const std::string& what)
{
  size_t count = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size()))
    ++count;
  return count;
}

// An xtion_node process started by the test, its output in a file.
class NodeProcess
{
public:
  NodeProcess(const std::string& name, const std::vector<std::string>& arguments)
      : log_((tempDir() / (name + ".log")).string())
  {
    std::vector<std::string> args = {XTION_NODE_PATH, "__name:=" + name};
    args.insert(args.end(), arguments.begin(), arguments.end());
    pid_ = ::fork();
    if (pid_ == 0)
    {
      const int fd = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      std::vector<char*> argv;
      for (std::string& arg : args)
        argv.push_back(arg.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
  }
  ~NodeProcess()
  {
    if (running())
    {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  bool running()
  {
    if (exited_)
      return false;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_)
    {
      exited_ = true;
      status_ = status;
      return false;
    }
    return true;
  }
  // SIGINT, then the exit status (-1: still running after `seconds`, killed).
  int interrupt(double seconds = 10.0)
  {
    if (running())
      ::kill(pid_, SIGINT);
    if (!waitUntil([this] { return !running(); }, seconds))
      return -1;
    return status_;
  }
  std::string log() const { return readFile(log_); }
  // User + system CPU seconds so far.
  double cpuSeconds() const
  {
    std::istringstream stat(readFile("/proc/" + std::to_string(pid_) + "/stat"));
    std::string field;
    std::vector<std::string> fields;
    // The command name (field 2) has no spaces here.
    while (stat >> field)
      fields.push_back(field);
    if (fields.size() < 15)
      return -1.0;
    return (std::stod(fields[13]) + std::stod(fields[14])) / static_cast<double>(::sysconf(_SC_CLK_TCK));
  }
  // CPU use in % of one core over `seconds`.
  double cpuPercent(double seconds)
  {
    const double cpu0 = cpuSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    const double cpu1 = cpuSeconds();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return 100.0 * (cpu1 - cpu0) / wall;
  }
  pid_t pid() const { return pid_; }

private:
  std::string log_;
  pid_t pid_ = -1;
  bool exited_ = false;
  int status_ = 0;
};

bool exitedCleanly(int status)
{
  return status >= 0 && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

void checkCameraInfo(const sensor_msgs::CameraInfo& info, const sensor_msgs::Image& image)
{
  EXPECT_EQ(info.width, image.width);
  EXPECT_EQ(info.height, image.height);
  EXPECT_EQ(info.header.frame_id, image.header.frame_id);
  EXPECT_GT(info.K[0], 0.0);
  EXPECT_GT(info.K[4], 0.0);
  EXPECT_GT(info.K[2], 0.0);
  EXPECT_LT(info.K[2], image.width);
  EXPECT_GT(info.K[5], 0.0);
  EXPECT_LT(info.K[5], image.height);
  EXPECT_DOUBLE_EQ(info.P[0], info.K[0]);
  EXPECT_DOUBLE_EQ(info.P[10], 1.0);
  EXPECT_EQ(info.distortion_model, "plumb_bob");
}

// One image stream (rgb or depth) of the node: rate, encoding, size, frame, stamps and its camera_info.
void checkImageStream(Received& received, bool color)
{
  const double rate = received.rate();
  std::printf("%s: %zu images, %.2f Hz\n", color ? "rgb/image_raw" : "depth_registered/image_raw", received.count(),
              rate);
  EXPECT_NEAR(rate, g_fps, 0.15 * g_fps) << (color ? "rgb" : "depth");
  std::lock_guard<std::mutex> lock(received.mutex);
  ASSERT_GT(received.images.size(), 10u);
  ASSERT_GT(received.infos.size(), 10u);
  std::map<double, const sensor_msgs::CameraInfo*> info_by_stamp;
  for (const auto& info : received.infos)
    info_by_stamp[info->header.stamp.toSec()] = info.get();
  size_t with_info = 0;
  for (const auto& image : received.images)
  {
    EXPECT_EQ(image->encoding, color ? "rgb8" : "16UC1");
    EXPECT_EQ(image->width, static_cast<uint32_t>(g_width));
    EXPECT_EQ(image->height, static_cast<uint32_t>(g_height));
    EXPECT_EQ(image->step, image->width * (color ? 3u : 2u));
    EXPECT_EQ(image->data.size(), static_cast<size_t>(image->step) * image->height);
    // DummyDevice has no registration: depth stays in the depth camera's frame.
    EXPECT_EQ(image->header.frame_id, color ? "camera_rgb_optical_frame" : "camera_depth_optical_frame");
    EXPECT_NEAR(image->header.stamp.toSec(), ros::Time::now().toSec(), 5.0);
    const auto info = info_by_stamp.find(image->header.stamp.toSec());
    if (info != info_by_stamp.end())
    {
      ++with_info;
      checkCameraInfo(*info->second, *image);
    }
  }
  EXPECT_GE(with_info, received.images.size() * 8 / 10) << "camera_info shares its image's stamp";
  if (!color)
  {
    // DummyDevice's depth: the first row is 2000 mm.
    const auto& image = *received.images.back();
    const auto* row = reinterpret_cast<const uint16_t*>(image.data.data());
    EXPECT_EQ(row[0], 2000);
    EXPECT_EQ(row[image.width - 1], 2000);
  }
}

// Synchronised: colour and depth frames of a pair carry one stamp.
void checkPairsShareStamps(CameraTopics& topics)
{
  std::lock_guard<std::mutex> lock_rgb(topics.rgb.mutex);
  std::lock_guard<std::mutex> lock_depth(topics.depth.mutex);
  std::set<double> rgb_stamps;
  for (const auto& image : topics.rgb.images)
    rgb_stamps.insert(image->header.stamp.toSec());
  size_t shared = 0;
  for (const auto& image : topics.depth.images)
    shared += rgb_stamps.count(image->header.stamp.toSec());
  EXPECT_GE(shared, topics.depth.images.size() * 8 / 10) << "paired colour/depth frames share a stamp";
}

// Points: organised, pcl::PointXYZRGB's layout, z = depth.
void checkPointCloud(const std::vector<sensor_msgs::PointCloud2ConstPtr>& clouds,
                     const std::vector<double>& cloud_arrivals)
{
  ASSERT_FALSE(clouds.empty()) << "no depth_registered/points";
  const double rate =
      cloud_arrivals.size() > 5 ? (cloud_arrivals.size() - 4) / (cloud_arrivals.back() - cloud_arrivals[3]) : 0.0;
  std::printf("depth_registered/points: %.2f Hz\n", rate);
  EXPECT_NEAR(rate, g_fps, 0.2 * g_fps);
  const sensor_msgs::PointCloud2& cloud = *clouds.back();
  EXPECT_EQ(cloud.width, static_cast<uint32_t>(g_width));
  EXPECT_EQ(cloud.height, static_cast<uint32_t>(g_height));
  EXPECT_EQ(cloud.header.frame_id, "camera_depth_optical_frame");
  EXPECT_EQ(cloud.point_step, 32u);
  std::set<std::string> names;
  for (const auto& field : cloud.fields)
    names.insert(field.name);
  EXPECT_EQ(names, (std::set<std::string>{"x", "y", "z", "rgb"}));
  sensor_msgs::PointCloud2ConstIterator<float> z(cloud, "z");
  EXPECT_NEAR(*z, 2.0f, 1e-6f) << "first row of DummyDevice's depth is 2000 mm";
}

void checkOpticalFrames()
{
  // Static transforms camera_link -> optical frames (z forward = camera_link x, y down = -z).
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  for (const char* frame : {"camera_rgb_optical_frame", "camera_depth_optical_frame"})
  {
    std::string error;
    ASSERT_TRUE(buffer.canTransform("camera_link", frame, ros::Time(0), ros::Duration(5.0), &error)) << error;
    const auto t = buffer.lookupTransform("camera_link", frame, ros::Time(0));
    const auto& q = t.transform.rotation;
    // Rotate optical z (0,0,1) into camera_link: the third column of R(q).
    const double zx = 2 * (q.x * q.z + q.w * q.y);
    const double zy = 2 * (q.y * q.z - q.w * q.x);
    const double zz = 1 - 2 * (q.x * q.x + q.y * q.y);
    EXPECT_NEAR(zx, 1.0, 1e-9) << frame;
    EXPECT_NEAR(zy, 0.0, 1e-9) << frame;
    EXPECT_NEAR(zz, 0.0, 1e-9) << frame;
  }
}
}  // namespace

TEST(XtionNode, PublishesEveryTopicAtTheConfiguredRate)
{
  CameraTopics topics("/camera");
  std::mutex points_mutex;
  std::vector<sensor_msgs::PointCloud2ConstPtr> clouds;
  std::vector<double> cloud_arrivals;
  ros::NodeHandle nh;
  ros::Subscriber points = nh.subscribe<sensor_msgs::PointCloud2>(
      "/camera/depth_registered/points", 5, [&](const sensor_msgs::PointCloud2ConstPtr& cloud) {
        std::lock_guard<std::mutex> lock(points_mutex);
        clouds.push_back(cloud);
        cloud_arrivals.push_back(ros::WallTime::now().toSec());
        if (clouds.size() > 5)
          clouds.erase(clouds.begin());
      });
  ASSERT_TRUE(waitUntil([&] { return topics.rgb.count() > 0 && topics.depth.count() > 0; }, 20.0))
      << "no images from the launched xtion_node";
  topics.rgb.clear();
  topics.depth.clear();
  std::this_thread::sleep_for(std::chrono::seconds(4));

  checkImageStream(topics.rgb, true);
  checkImageStream(topics.depth, false);
  checkPairsShareStamps(topics);
  {
    std::lock_guard<std::mutex> lock(points_mutex);
    checkPointCloud(clouds, cloud_arrivals);
  }
  checkOpticalFrames();
}

TEST(XtionNode, PlaysBackARecordingAsTheSameFramesAndStopsCleanly)
{
  // Record from DummyDevice with OpenNI2's recorder, remembering each frame read meanwhile.
  const std::string path = (tempDir() / "dummy.oni").string();
  std::set<uint64_t> recorded[2];
  {
    dr::OpenniConfig config;
    config.uri = "Dummy";
    config.color_mode = config.depth_mode = {g_width, g_height, g_fps};
    const auto status = dr::recordOni(config, path, 3.0, [&](const dr::FrameView& frame) {
      const size_t row = static_cast<size_t>(frame.width) * (frame.stream == dr::StreamKind::kColor ? 3 : 2);
      uint64_t hash = 1469598103934665603ull;
      for (int y = 0; y < frame.height; ++y)
        hash = fnv(frame.data + y * frame.stride_bytes, row, hash);
      recorded[frame.stream == dr::StreamKind::kColor ? 0 : 1].insert(hash);
    });
    ASSERT_TRUE(status) << status.error().describe();
  }
  std::printf("recorded %zu colour and %zu depth frames to %s\n", recorded[0].size(), recorded[1].size(), path.c_str());
  ASSERT_GE(recorded[0].size(), 60u);
  ASSERT_GE(recorded[1].size(), 60u);

  CameraTopics topics("/playback");
  NodeProcess node("xtion_playback", {"__ns:=/playback", "_device_uri:=" + path});
  ASSERT_TRUE(waitUntil([&] { return topics.rgb.count() > 0 && topics.depth.count() > 0; }, 20.0)) << node.log();
  std::this_thread::sleep_for(std::chrono::seconds(4));
  for (int k = 0; k < 2; ++k)
  {
    Received& received = k == 0 ? topics.rgb : topics.depth;
    const double rate = received.rate();
    std::lock_guard<std::mutex> lock(received.mutex);
    size_t matched = 0;
    for (uint64_t hash : received.hashes)
      matched += recorded[k].count(hash);
    std::printf("%s playback: %zu frames at %.2f Hz, %zu of them recorded frames\n", k == 0 ? "colour" : "depth",
                received.hashes.size(), rate, matched);
    EXPECT_GE(received.hashes.size(), 90u);
    EXPECT_GE(matched, received.hashes.size() * 9 / 10) << "playback publishes the recorded frames";
    EXPECT_NEAR(rate, g_fps, 0.15 * g_fps);
    ASSERT_FALSE(received.images.empty());
    EXPECT_EQ(received.images.back()->encoding, k == 0 ? "rgb8" : "16UC1");
    EXPECT_EQ(received.images.back()->width, static_cast<uint32_t>(g_width));
  }
  const int status = node.interrupt();
  EXPECT_TRUE(exitedCleanly(status)) << "status " << status << "\n" << node.log();
  EXPECT_NE(node.log().find("streams stopped, device closed"), std::string::npos) << node.log();
}

TEST(XtionNode, ReportsALostDeviceAndResumes)
{
  // The end of a recording played once looks like an unplugged device: frames stop. The node says so, closes it,
  // retries, and publishes again when the "device" is back.
  const std::string path = (tempDir() / "short.oni").string();
  {
    dr::OpenniConfig config;
    config.uri = "Dummy";
    config.color_mode = config.depth_mode = {g_width, g_height, g_fps};
    const auto status = dr::recordOni(config, path, 1.5);
    ASSERT_TRUE(status) << status.error().describe();
  }
  CameraTopics topics("/lost");
  NodeProcess node("xtion_lost", {"__ns:=/lost", "_device_uri:=" + path, "_oni_loop:=false", "_frame_timeout:=1.0",
                                  "_retry_period:=0.5"});
  ASSERT_TRUE(waitUntil([&] { return topics.depth.count() > 0; }, 20.0)) << node.log();
  // Played once (~1.5 s), 1 s without frames, 0.5 s retry, played again.
  ASSERT_TRUE(waitUntil([&] { return node.log().find("publishing again") != std::string::npos; }, 15.0)) << node.log();
  const std::string log = node.log();
  EXPECT_NE(log.find("the recording ended"), std::string::npos) << log;
  EXPECT_NE(log.find("Retrying every 0.5 s"), std::string::npos) << log;
  const size_t before = topics.depth.count();
  EXPECT_TRUE(waitUntil([&] { return topics.depth.count() > before + 10; }, 5.0)) << "publishing resumed";
  EXPECT_TRUE(node.running());
  EXPECT_TRUE(exitedCleanly(node.interrupt())) << node.log();
}

TEST(XtionNode, NoDeviceGivesTheMessageAndRetriesWithoutSpinning)
{
  NodeProcess node("xtion_missing", {"__ns:=/missing", "_device_uri:=no/such@device", "_retry_period:=0.5",
                                     "_fault_report_period:=1.0"});
  std::this_thread::sleep_for(std::chrono::seconds(2));
  ASSERT_TRUE(node.running()) << node.log();
  const double cpu = node.cpuPercent(3.0);
  std::printf("xtion_node without a device: %.2f %% of one core\n", cpu);
  EXPECT_LT(cpu, 5.0) << "waiting for a device must not spin";
  const std::string log = node.log();
  EXPECT_NE(log.find("cannot open device 'no/such@device'"), std::string::npos) << log;
  EXPECT_NE(log.find("Retrying every 0.5 s"), std::string::npos) << log;
  EXPECT_NE(log.find("Set device_uri to"), std::string::npos) << log;
  // The same fault is repeated at most once per fault_report_period, with the attempts counted.
  EXPECT_GE(occurrences(log, "still failing after"), 2u) << log;
  EXPECT_LE(occurrences(log, "cannot open device"), 8u) << log;
  EXPECT_TRUE(node.running());
  EXPECT_TRUE(exitedCleanly(node.interrupt())) << node.log();
}

TEST(XtionNode, UnsupportedModeListsTheDeviceModes)
{
  NodeProcess node("xtion_mode", {"__ns:=/mode", "_device_uri:=Dummy", "_color_mode:=640x480@30"});
  ASSERT_TRUE(waitUntil([&] { return node.log().find("does not offer") != std::string::npos; }, 10.0)) << node.log();
  const std::string log = node.log();
  EXPECT_NE(log.find("the device does not offer the colour mode 640x480@30"), std::string::npos) << log;
  EXPECT_NE(log.find("it offers: 320x240@30 RGB888"), std::string::npos) << log;
  EXPECT_NE(log.find("Set color_mode to one of: 320x240@30"), std::string::npos) << log;
  EXPECT_TRUE(node.running());
  EXPECT_TRUE(exitedCleanly(node.interrupt())) << node.log();
}

TEST(XtionNode, MalformedParameterStopsWithTheReason)
{
  NodeProcess node("xtion_bad", {"__ns:=/bad", "_device_uri:=Dummy", "_depth_mode:=640by480"});
  ASSERT_TRUE(waitUntil([&] { return !node.running(); }, 10.0));
  const int status = node.interrupt();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << status;
  EXPECT_NE(node.log().find("parameter ~depth_mode: video mode '640by480' is not WIDTHxHEIGHT@FPS"), std::string::npos)
      << node.log();
}

// Every bad parameter is named with its value and the allowed range (issue 16). roscpp types a _x:=value argument as
// an integer, a number (inf included) or else a string; the list comes through the parameter server.
TEST(XtionNode, BadParametersAreEachReported)
{
  ros::param::set("/bad_numbers/xtion_bad_numbers/rgb_xyz", std::vector<double>{0.0, 2.0, 0.0});
  NodeProcess node("xtion_bad_numbers", {"__ns:=/bad_numbers", "_device_uri:=Dummy", "_oni_speed:=-1",
                                         "_retry_period:=fast", "_fault_report_period:=inf", "_depth_xyz:=0.1"});
  ASSERT_TRUE(waitUntil([&] { return !node.running(); }, 10.0));
  const int status = node.interrupt();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << status;
  for (const char* message : {"parameter ~oni_speed is -1, allowed: a number in (0, 100]",
                              "parameter ~retry_period is the string 'fast', allowed: a number in [0.1, 3600] s",
                              "parameter ~fault_report_period is inf, allowed: a number in [0, 86400] s",
                              "parameter ~rgb_xyz[1] is 2, allowed: a number in [-1, 1] m",
                              "parameter ~depth_xyz is the number 0.1, allowed: a list of 3 numbers"})
    EXPECT_NE(node.log().find(message), std::string::npos) << message << "\n" << node.log();
}

TEST(XtionNode, CpuUse)
{
  // Both streams subscribed, DummyDevice's 320x240 at 30 Hz. (docs/xtion.md has the 640x480 measurement.)
  CameraTopics topics("/cpu");
  NodeProcess node("xtion_cpu",
                   {"__ns:=/cpu", "_device_uri:=Dummy", "_color_mode:=320x240@30", "_depth_mode:=320x240@30"});
  ASSERT_TRUE(waitUntil([&] { return topics.rgb.count() > 0 && topics.depth.count() > 0; }, 20.0)) << node.log();
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const double cpu = node.cpuPercent(5.0);
  std::printf("xtion_node, DummyDevice %dx%d@%d, both streams subscribed: %.2f %% of one core\n", g_width, g_height,
              g_fps, cpu);
  EXPECT_LT(cpu, 15.0);
  EXPECT_TRUE(exitedCleanly(node.interrupt())) << node.log();
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_xtion_driver");
  ros::NodeHandle pnh("~");
  pnh.param("fps", g_fps, g_fps);
  pnh.param("width", g_width, g_width);
  pnh.param("height", g_height, g_height);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  std::error_code ignored;
  fs::remove_all(tempDir(), ignored);
  return result;
}
