// The OpenNI2 device layer of the Xtion driver, against OpenNI2's DummyDevice (URI "Dummy": 320x240 at 30 Hz,
// RGB888 colour and DEPTH_1_MM depth, no registration, no field of view) and recordings made from it.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <string>

#include "insitu_calibration/drivers/frame_stamper.h"
#include "insitu_calibration/drivers/openni_device.h"
#include "insitu_calibration/drivers/oni_writer.h"

namespace dr = insitu_calibration::drivers;
namespace fs = std::filesystem;

namespace
{
fs::path tempDir()
{
  const fs::path dir = fs::temp_directory_path() / ("insitu_openni_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

dr::OpenniConfig dummyConfig()
{
  dr::OpenniConfig config;
  config.uri = "Dummy";
  config.color_mode = {320, 240, 30};
  config.depth_mode = {320, 240, 30};
  return config;
}

// A frame's content as a key: stream, size and a 64-bit FNV-1a hash of the pixels.
std::string frameKey(const dr::FrameView& frame)
{
  const size_t row = static_cast<size_t>(frame.width) * (frame.stream == dr::StreamKind::kColor ? 3 : 2);
  uint64_t hash = 1469598103934665603ull;
  for (int y = 0; y < frame.height; ++y)
    for (size_t x = 0; x < row; ++x)
      hash = (hash ^ frame.data[y * frame.stride_bytes + x]) * 1099511628211ull;
  return std::string(dr::toString(frame.stream)) + std::to_string(frame.width) + "x" + std::to_string(frame.height) +
         ":" + std::to_string(hash);
}

// Reads frames for `seconds`; counts them per stream.
std::map<dr::StreamKind, int> readFor(dr::OpenniDevice& device, double seconds,
                                      const std::function<void(const dr::FrameView&)>& also = {})
{
  std::map<dr::StreamKind, int> counts;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end)
  {
    const auto read = device.readFrame(200, [&](const dr::FrameView& frame) {
      ++counts[frame.stream];
      if (also)
        also(frame);
    });
    EXPECT_TRUE(read) << read.error().describe();
    if (!read)
      break;
  }
  return counts;
}
}  // namespace

TEST(VideoMode, Parse)
{
  const auto mode = dr::parseVideoMode("640x480@30");
  ASSERT_TRUE(mode);
  EXPECT_EQ(mode->width, 640);
  EXPECT_EQ(mode->height, 480);
  EXPECT_EQ(mode->fps, 30);
  EXPECT_EQ(mode->toString(), "640x480@30");
  const auto no_rate = dr::parseVideoMode("320x240");
  ASSERT_TRUE(no_rate);
  EXPECT_EQ(no_rate->fps, 30);
  for (const char* bad : {"", "640", "640x", "640x480@", "640x480@30Hz", "-640x480@30", "axb@c", "640*480@30"})
  {
    const auto parsed = dr::parseVideoMode(bad);
    EXPECT_FALSE(parsed) << bad;
    if (!parsed)
    {
      EXPECT_NE(parsed.error().message().find("WIDTHxHEIGHT@FPS"), std::string::npos);
    }
  }
}

TEST(VideoMode, ChooseListsWhatTheDeviceOffers)
{
  const std::vector<dr::OfferedMode> offered = {
      {{320, 240, 30}, "RGB888", true}, {{640, 480, 30}, "YUV422", false}, {{1280, 1024, 15}, "RGB888", true}};
  const auto chosen = dr::chooseMode(dr::StreamKind::kColor, offered, {1280, 1024, 15}, "color_mode");
  ASSERT_TRUE(chosen);
  EXPECT_EQ(*chosen, 2u);
  // 640x480 exists only in a pixel format the driver does not publish.
  const auto missing = dr::chooseMode(dr::StreamKind::kColor, offered, {640, 480, 30}, "color_mode");
  ASSERT_FALSE(missing);
  const std::string message = missing.error().message();
  EXPECT_NE(message.find("640x480@30"), std::string::npos) << message;
  EXPECT_NE(message.find("320x240@30 RGB888, 640x480@30 YUV422, 1280x1024@15 RGB888"), std::string::npos) << message;
  EXPECT_NE(message.find("Set color_mode to one of: 320x240@30, 1280x1024@15"), std::string::npos) << message;
}

TEST(FrameStamper, RemovesLatencyJitterAndPairs)
{
  dr::FrameStamper stamper(true, 30);
  const double host0 = 1000.0;
  // Device frames every 33 ms; host reads them with 5..15 ms of latency. The stamp is the device time plus the
  // smallest latency seen so far.
  const double latencies[] = {0.015, 0.005, 0.010, 0.012};
  double previous = 0.0;
  for (int i = 0; i < 4; ++i)
  {
    const uint64_t device_us = 33000u * (i + 1);
    const double host = host0 + device_us * 1e-6 + latencies[i];
    const double color = stamper.stamp(dr::StreamKind::kColor, device_us, host);
    const double depth = stamper.stamp(dr::StreamKind::kDepth, device_us + 2000, host + 0.002);
    EXPECT_DOUBLE_EQ(color, depth) << "a synchronised pair shares one stamp";
    if (i >= 1)
    {
      EXPECT_NEAR(color, host0 + device_us * 1e-6 + 0.005, 1e-4);  // plus the allowed drift
    }
    EXPECT_GT(color, previous);
    previous = color;
  }
  // The device clock starts again (a recording looping): stamps follow the host clock again.
  const double after = stamper.stamp(dr::StreamKind::kColor, 33000, host0 + 10.0);
  EXPECT_NEAR(after, host0 + 10.0, 1e-9);

  dr::FrameStamper unpaired(false, 30);
  const double c = unpaired.stamp(dr::StreamKind::kColor, 33000, 5.0);
  const double d = unpaired.stamp(dr::StreamKind::kDepth, 35000, 5.002);
  EXPECT_NEAR(d - c, 0.002, 1e-9);
}

TEST(OpenniDevice, DummyDeliversBothStreams)
{
  dr::OpenniDevice device;
  const auto opened = device.open(dummyConfig());
  ASSERT_TRUE(opened) << opened.error().describe();
  const dr::DeviceSummary& summary = device.summary();
  EXPECT_EQ(summary.uri, "Dummy");
  EXPECT_FALSE(summary.is_file);
  EXPECT_EQ(summary.color_mode, (dr::VideoModeSpec{320, 240, 30}));
  EXPECT_EQ(summary.depth_mode, (dr::VideoModeSpec{320, 240, 30}));
  EXPECT_FALSE(summary.registration_supported);
  EXPECT_FALSE(summary.registration_on);
  std::printf("%s\n", summary.describe().c_str());
  bool sizes_ok = true;
  const auto counts = readFor(device, 1.0, [&](const dr::FrameView& frame) {
    sizes_ok = sizes_ok && frame.width == 320 && frame.height == 240;
  });
  EXPECT_TRUE(sizes_ok);
  EXPECT_GE(counts.count(dr::StreamKind::kColor) ? counts.at(dr::StreamKind::kColor) : 0, 20);
  EXPECT_GE(counts.count(dr::StreamKind::kDepth) ? counts.at(dr::StreamKind::kDepth) : 0, 20);
  device.close();
  EXPECT_FALSE(device.isOpen());
}

TEST(OpenniDevice, ReopensAfterClose)
{
  dr::OpenniDevice device;
  for (int i = 0; i < 3; ++i)
  {
    const auto opened = device.open(dummyConfig());
    ASSERT_TRUE(opened) << opened.error().describe();
    const auto counts = readFor(device, 0.3);
    EXPECT_GT(counts.size(), 0u);
    device.close();
  }
}

TEST(OpenniDevice, UnsupportedModeListsTheModes)
{
  dr::OpenniDevice device;
  dr::OpenniConfig config = dummyConfig();
  config.color_mode = {640, 480, 30};
  const auto opened = device.open(config);
  ASSERT_FALSE(opened);
  const std::string message = opened.error().message();
  EXPECT_NE(message.find("colour mode 640x480@30"), std::string::npos) << message;
  EXPECT_NE(message.find("320x240@30 RGB888"), std::string::npos) << message;
  EXPECT_NE(message.find("color_mode"), std::string::npos) << message;
  EXPECT_FALSE(device.isOpen());
}

TEST(OpenniDevice, NoSuchDevice)
{
  dr::OpenniDevice device;
  dr::OpenniConfig config = dummyConfig();
  config.uri = "no/such@device";
  const auto opened = device.open(config);
  ASSERT_FALSE(opened);
  EXPECT_NE(opened.error().message().find("cannot open device 'no/such@device'"), std::string::npos)
      << opened.error().message();
  config.uri = "#7";
  const auto by_index = device.open(config);
  ASSERT_FALSE(by_index);
  EXPECT_NE(by_index.error().message().find("asks for device 7"), std::string::npos) << by_index.error().message();
}

TEST(OpenniDevice, UnreadableRecordings)
{
  dr::OpenniDevice device;
  dr::OpenniConfig config = dummyConfig();
  config.uri = (tempDir() / "missing.oni").string();
  auto opened = device.open(config);
  ASSERT_FALSE(opened);
  EXPECT_NE(opened.error().message().find("cannot read the recording"), std::string::npos) << opened.error().message();
  config.uri = (tempDir() / "garbage.oni").string();
  std::ofstream(config.uri) << "this is not a recording\n";
  opened = device.open(config);
  ASSERT_FALSE(opened);
  EXPECT_NE(opened.error().message().find("not an OpenNI2 recording"), std::string::npos) << opened.error().message();
  // Right magic, damaged body.
  std::ofstream(config.uri, std::ios::binary) << "NI10" << std::string(100, '\x7f');
  opened = device.open(config);
  ASSERT_FALSE(opened);
  EXPECT_NE(opened.error().message().find("cannot play the recording"), std::string::npos) << opened.error().message();
}

TEST(OpenniDevice, RecordsAndPlaysBackTheSameFrames)
{
  const std::string path = (tempDir() / "dummy.oni").string();
  std::set<std::string> recorded;
  {
    dr::OpenniDevice device;
    ASSERT_TRUE(device.open(dummyConfig()));
    const auto status = device.record(path, 1.5, [&](const dr::FrameView& frame) { recorded.insert(frameKey(frame)); });
    ASSERT_TRUE(status) << status.error().describe();
  }
  EXPECT_GE(recorded.size(), 60u);
  // Already fixed up by record(): nothing left to do.
  const auto again = dr::addCroppingToOniRecording(path);
  ASSERT_TRUE(again) << again.error().describe();
  EXPECT_EQ(*again, 0);

  dr::OpenniDevice player;
  dr::OpenniConfig config;
  config.uri = path;
  config.oni_loop = false;
  // Played at half speed: OpenNI drops the frames a busy reader misses, and on a loaded machine (two calibrations
  // beside the test suite) a real-time reader missed enough to fail the count below.
  config.oni_speed = 0.5;
  const auto opened = player.open(config);
  ASSERT_TRUE(opened) << opened.error().describe();
  EXPECT_TRUE(player.summary().is_file);
  EXPECT_EQ(player.summary().color_mode, (dr::VideoModeSpec{320, 240, 30}));
  std::map<dr::StreamKind, int> matched;
  int frames = 0;
  readFor(player, 4.0, [&](const dr::FrameView& frame) {
    ++frames;
    if (recorded.count(frameKey(frame)))
      ++matched[frame.stream];
  });
  // The recording holds ~45 frames a stream; the reader saw (nearly) all of them while recording.
  EXPECT_GE(matched[dr::StreamKind::kColor], 35) << frames << " frames played";
  EXPECT_GE(matched[dr::StreamKind::kDepth], 35) << frames << " frames played";
  EXPECT_GE(matched[dr::StreamKind::kColor] + matched[dr::StreamKind::kDepth], frames * 9 / 10);
}

TEST(OniWriter, SyntheticRecordingPlaysAt640x480)
{
  const std::string path = (tempDir() / "synthetic.oni").string();
  dr::SyntheticOniOptions options;
  options.mode = {640, 480, 30};
  options.frames = 20;
  const auto written = dr::writeSyntheticOni(path, options);
  ASSERT_TRUE(written) << written.error().describe();

  dr::OpenniDevice player;
  dr::OpenniConfig config;
  config.uri = path;
  config.oni_loop = false;
  const auto opened = player.open(config);
  ASSERT_TRUE(opened) << opened.error().describe();
  EXPECT_EQ(player.summary().color_mode, (dr::VideoModeSpec{640, 480, 30}));
  EXPECT_EQ(player.summary().depth_mode, (dr::VideoModeSpec{640, 480, 30}));
  EXPECT_NEAR(player.summary().color_hfov, options.hfov, 1e-6);
  EXPECT_NEAR(player.summary().depth_vfov, options.vfov, 1e-6);
  std::map<dr::StreamKind, int> good;
  readFor(player, 1.2, [&](const dr::FrameView& frame) {
    ASSERT_EQ(frame.width, 640);
    ASSERT_EQ(frame.height, 480);
    const int k = frame.frame_index - 1;
    bool same = true;
    for (int y = 0; y < frame.height && same; y += 7)
      for (int x = 0; x < frame.width && same; x += 5)
      {
        const uint8_t* p = frame.data + y * frame.stride_bytes;
        if (frame.stream == dr::StreamKind::kColor)
          same = p[3 * x] == dr::syntheticColor(options, k, x, y, 0) &&
                 p[3 * x + 1] == dr::syntheticColor(options, k, x, y, 1) &&
                 p[3 * x + 2] == dr::syntheticColor(options, k, x, y, 2);
        else
          same = reinterpret_cast<const uint16_t*>(p)[x] == dr::syntheticDepth(options, k, x, y);
      }
    good[frame.stream] += same;
  });
  EXPECT_GE(good[dr::StreamKind::kColor], 15);
  EXPECT_GE(good[dr::StreamKind::kDepth], 15);
}
