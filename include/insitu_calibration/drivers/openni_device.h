// An RGB-D device opened through OpenNI2 (Asus Xtion / PrimeSense PS1080, an .oni recording, or OpenNI2's
// DummyDevice): device selection, video modes, hardware registration and frame synchronisation, the colour and depth
// streams, disconnection and a clean shutdown. ROS-free: the ROS node (src/ros/xtion_driver.cpp) publishes what this
// class reads. OpenNI2 itself stays behind the implementation (no OpenNI header here).
#ifndef INSITU_CALIBRATION_DRIVERS_OPENNI_DEVICE_H
#define INSITU_CALIBRATION_DRIVERS_OPENNI_DEVICE_H

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "insitu_calibration/error.h"

namespace insitu_calibration
{
namespace drivers
{
enum class StreamKind
{
  kColor,  // RGB888, 3 bytes a pixel
  kDepth,  // 16-bit millimetres, 0 = no return
};
const char* toString(StreamKind kind);

// A stream's resolution and frame rate, written "640x480@30".
struct VideoModeSpec
{
  int width = 0;
  int height = 0;
  int fps = 0;

  std::string toString() const;
  bool operator==(const VideoModeSpec& other) const
  {
    return width == other.width && height == other.height && fps == other.fps;
  }
  bool operator!=(const VideoModeSpec& other) const { return !(*this == other); }
};
// "640x480@30" (also "640x480" = 30 Hz). An error says the expected form.
Expected<VideoModeSpec> parseVideoMode(const std::string& text);

// A mode a device offers: resolution, rate and OpenNI2 pixel format ("RGB888", "DEPTH_1_MM", "YUV422", ...).
struct OfferedMode
{
  VideoModeSpec mode;
  std::string pixel_format;
  bool usable = false;  // in a pixel format this driver publishes (RGB888 for colour, DEPTH_1_MM for depth)
};
// "320x240@30 RGB888, 640x480@30 RGB888" (or "none").
std::string describeModes(const std::vector<OfferedMode>& modes);
// Index in `offered` of the usable mode equal to `wanted`, or an error that names the stream, the wanted mode and
// every mode the device offers, and says which parameter to change.
Expected<size_t> chooseMode(StreamKind kind, const std::vector<OfferedMode>& offered, const VideoModeSpec& wanted,
                            const std::string& parameter_name);

// What to open and how.
struct OpenniConfig
{
  // "" = the first device found; "#2" = the second device found; a device URI ("1d27/0601@3/7", "Dummy"); a serial
  // number; or the path of an .oni recording.
  std::string uri;
  VideoModeSpec color_mode{640, 480, 30};
  VideoModeSpec depth_mode{640, 480, 30};
  bool registration = true;  // hardware depth-to-colour registration, when the device supports it
  bool sync = true;          // colour/depth frame synchronisation, when the device supports it
  // Recordings: play in a loop, at this speed (1 = as recorded). Their modes are what was recorded.
  bool oni_loop = true;
  double oni_speed = 1.0;
};

// What was opened, for the log and for camera_info.
struct DeviceSummary
{
  std::string uri;  // as OpenNI2 reports it (a recording: its path)
  std::string name;
  std::string vendor;
  std::string serial;  // empty when the device has none
  bool is_file = false;
  bool registration_supported = false;
  bool registration_on = false;
  bool sync_on = false;
  VideoModeSpec color_mode;
  VideoModeSpec depth_mode;
  // Fields of view in radians as the device reports them; 0 when it reports none (DummyDevice, some recordings).
  double color_hfov = 0.0, color_vfov = 0.0;
  double depth_hfov = 0.0, depth_vfov = 0.0;
  std::vector<OfferedMode> color_modes;
  std::vector<OfferedMode> depth_modes;

  std::string describe() const;  // one line for the log
};

// One frame as the device delivered it; the data is valid only during the callback that receives it.
struct FrameView
{
  StreamKind stream = StreamKind::kColor;
  int width = 0;
  int height = 0;
  size_t stride_bytes = 0;
  uint64_t device_time_us = 0;  // the device clock
  int frame_index = 0;
  const uint8_t* data = nullptr;
};

// The devices OpenNI2 enumerates (not DummyDevice, which is opened by its URI only).
struct DeviceListEntry
{
  std::string uri;
  std::string name;
  std::string vendor;
};
Expected<std::vector<DeviceListEntry>> listDevices();

class OpenniDevice
{
public:
  OpenniDevice();
  ~OpenniDevice();  // close()
  OpenniDevice(const OpenniDevice&) = delete;
  OpenniDevice& operator=(const OpenniDevice&) = delete;

  // Resolves config.uri, opens the device, checks and sets the modes, turns on registration and sync where
  // supported, and starts both streams. On error the device is left closed and the message says what to do.
  Status open(const OpenniConfig& config);
  bool isOpen() const;
  const DeviceSummary& summary() const;

  // Waits up to timeout_ms for a frame of either stream (blocking, no busy wait). Returns true after passing the
  // frame to `sink`, false on timeout, an error when the device failed (then close() and open() again).
  Expected<bool> readFrame(int timeout_ms, const std::function<void(const FrameView&)>& sink);
  // True once OpenNI2 has reported the open device disconnected (unplugged).
  bool disconnected() const;

  // Records `seconds` of both open streams to an .oni file with OpenNI2's recorder (lossless), passing every frame it
  // reads meanwhile to `on_frame`; then fixes the file up for playback if needed (addCroppingToOniRecording).
  Status record(const std::string& path, double seconds, const std::function<void(const FrameView&)>& on_frame = {});

  // Stops the streams, lets the driver's frame threads finish, destroys the streams, then closes the device (the
  // reverse order crashes OpenNI2). Safe to call twice.
  void close();

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Records `seconds` of both streams of the device at `uri` (modes as in `config`) to an .oni file with OpenNI2's
// recorder. `on_frame` (optional) sees every frame read while recording. Recordings of a device whose streams have no
// cropping property (DummyDevice) are fixed up so that OpenNI2's file player can play them.
Status recordOni(const OpenniConfig& config, const std::string& path, double seconds,
                 const std::function<void(const FrameView&)>& on_frame = {});

// OpenNI2's file player drops every frame of a stream whose recording has no "xnCropping" property (recordings of
// DummyDevice). This rewrites each stream's "xnIsGenerating" record (OpenNI 1 only, the same size) into an
// "xnCropping = off" record in place. Returns how many streams it fixed (0 when nothing needed fixing).
Expected<int> addCroppingToOniRecording(const std::string& path);

}  // namespace drivers
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_DRIVERS_OPENNI_DEVICE_H
