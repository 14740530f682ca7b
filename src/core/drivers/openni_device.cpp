#include "insitu_calibration/drivers/openni_device.h"

#include <OpenNI.h>

#include "drivers/oni_format.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

namespace insitu_calibration
{
namespace drivers
{
namespace
{
// OpenNI2 is process-wide: initialised by the first OpenniDevice, shut down after the last one.
std::mutex g_openni_mutex;
int g_openni_users = 0;

std::string extendedError()
{
  std::string text = openni::OpenNI::getExtendedError();
  // OpenNI2 indents its messages with a tab and ends them with newlines.
  text.erase(std::remove(text.begin(), text.end(), '\t'), text.end());
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())))
    text.pop_back();
  for (char& c : text)
    if (c == '\n')
      c = ';';
  return text.empty() ? "no details" : text;
}

Status acquireOpenni()
{
  std::lock_guard<std::mutex> lock(g_openni_mutex);
  if (g_openni_users == 0)
  {
    const openni::Status rc = openni::OpenNI::initialize();
    if (rc != openni::STATUS_OK)
      return Error(ErrorCode::kIoError, "OpenNI2 did not start (" + extendedError() +
                                            "): check that libopenni2-0 is installed and that its drivers are in "
                                            "/usr/lib/x86_64-linux-gnu/OpenNI2/Drivers");
  }
  ++g_openni_users;
  return Success{};
}

void releaseOpenni()
{
  std::lock_guard<std::mutex> lock(g_openni_mutex);
  if (g_openni_users > 0 && --g_openni_users == 0)
    openni::OpenNI::shutdown();
}

std::string pixelFormatName(openni::PixelFormat format)
{
  switch (format)
  {
    case openni::PIXEL_FORMAT_DEPTH_1_MM:
      return "DEPTH_1_MM";
    case openni::PIXEL_FORMAT_DEPTH_100_UM:
      return "DEPTH_100_UM";
    case openni::PIXEL_FORMAT_SHIFT_9_2:
      return "SHIFT_9_2";
    case openni::PIXEL_FORMAT_SHIFT_9_3:
      return "SHIFT_9_3";
    case openni::PIXEL_FORMAT_RGB888:
      return "RGB888";
    case openni::PIXEL_FORMAT_YUV422:
      return "YUV422";
    case openni::PIXEL_FORMAT_GRAY8:
      return "GRAY8";
    case openni::PIXEL_FORMAT_GRAY16:
      return "GRAY16";
    case openni::PIXEL_FORMAT_JPEG:
      return "JPEG";
    case openni::PIXEL_FORMAT_YUYV:
      return "YUYV";
  }
  return "format " + std::to_string(static_cast<int>(format));
}

openni::PixelFormat wantedFormat(StreamKind kind)
{
  return kind == StreamKind::kColor ? openni::PIXEL_FORMAT_RGB888 : openni::PIXEL_FORMAT_DEPTH_1_MM;
}

VideoModeSpec specOf(const openni::VideoMode& mode)
{
  return VideoModeSpec{mode.getResolutionX(), mode.getResolutionY(), mode.getFps()};
}

std::vector<OfferedMode> offeredModes(const openni::SensorInfo* info, StreamKind kind)
{
  std::vector<OfferedMode> result;
  if (info == nullptr)
    return result;
  const openni::Array<openni::VideoMode>& modes = info->getSupportedVideoModes();
  for (int i = 0; i < modes.getSize(); ++i)
    result.push_back(OfferedMode{specOf(modes[i]), pixelFormatName(modes[i].getPixelFormat()),
                                 modes[i].getPixelFormat() == wantedFormat(kind)});
  return result;
}

bool endsWithOni(const std::string& text)
{
  if (text.size() < 4)
    return false;
  std::string tail = text.substr(text.size() - 4);
  std::transform(tail.begin(), tail.end(), tail.begin(), [](unsigned char c) { return std::tolower(c); });
  return tail == ".oni";
}

std::string describeDeviceList(const std::vector<DeviceListEntry>& devices)
{
  if (devices.empty())
    return "none";
  std::string text;
  for (size_t i = 0; i < devices.size(); ++i)
  {
    if (i)
      text += ", ";
    text += "#" + std::to_string(i + 1) + " " + devices[i].uri + " (" + devices[i].vendor + " " + devices[i].name + ")";
  }
  return text;
}

std::string serialOf(openni::Device& device)
{
  char serial[ONI_MAX_STR] = {0};
  int size = sizeof(serial);
  if (device.getProperty(ONI_DEVICE_PROPERTY_SERIAL_NUMBER, serial, &size) != openni::STATUS_OK)
    return "";
  serial[sizeof(serial) - 1] = '\0';
  return serial;
}

const char* const kUriHelp =
    "Set device_uri to empty (the first device), '#N' (the N-th device), a serial number, a device URI or the path "
    "of an .oni recording.";
}  // namespace

const char* toString(StreamKind kind)
{
  return kind == StreamKind::kColor ? "colour" : "depth";
}

std::string VideoModeSpec::toString() const
{
  return std::to_string(width) + "x" + std::to_string(height) + "@" + std::to_string(fps);
}

Expected<VideoModeSpec> parseVideoMode(const std::string& text)
{
  VideoModeSpec mode;
  char x = 0;
  char at = 0;
  std::istringstream in(text);
  in >> mode.width >> x >> mode.height;
  if (!in.fail() && !in.eof())
    in >> at >> mode.fps;
  else if (!in.fail())
    mode.fps = 30;
  std::string rest;
  if (in.fail() || (x != 'x' && x != 'X') || (at != 0 && at != '@') || (in >> rest, !rest.empty()) || mode.width <= 0 ||
      mode.height <= 0 || mode.fps <= 0)
    return Error(ErrorCode::kInvalidInput,
                 "video mode '" + text + "' is not WIDTHxHEIGHT@FPS (for example 640x480@30)");
  return mode;
}

std::string describeModes(const std::vector<OfferedMode>& modes)
{
  if (modes.empty())
    return "none";
  std::string text;
  for (size_t i = 0; i < modes.size(); ++i)
  {
    if (i)
      text += ", ";
    text += modes[i].mode.toString() + " " + modes[i].pixel_format;
  }
  return text;
}

Expected<size_t> chooseMode(StreamKind kind, const std::vector<OfferedMode>& offered, const VideoModeSpec& wanted,
                            const std::string& parameter_name)
{
  for (size_t i = 0; i < offered.size(); ++i)
    if (offered[i].usable && offered[i].mode == wanted)
      return i;
  std::string usable;
  for (const OfferedMode& mode : offered)
    if (mode.usable && usable.find(mode.mode.toString()) == std::string::npos)
      usable += (usable.empty() ? "" : ", ") + mode.mode.toString();
  return Error(ErrorCode::kInvalidInput,
               std::string("the device does not offer the ") + toString(kind) + " mode " + wanted.toString() +
                   " (parameter " + parameter_name + "); it offers: " + describeModes(offered) + ". Set " +
                   parameter_name + " to one of: " + (usable.empty() ? "(none in a usable pixel format)" : usable));
}

std::string DeviceSummary::describe() const
{
  std::ostringstream out;
  out << (is_file ? "recording " : "device ") << uri;
  if (!vendor.empty() || !name.empty())
    out << " (" << vendor << (vendor.empty() || name.empty() ? "" : " ") << name << ")";
  if (!serial.empty())
    out << " serial " << serial;
  out << ": colour " << color_mode.toString() << ", depth " << depth_mode.toString() << ", registration "
      << (registration_on ? "on" : (registration_supported ? "off" : "not supported")) << ", sync "
      << (sync_on ? "on" : "off");
  return out.str();
}

Expected<std::vector<DeviceListEntry>> listDevices()
{
  const Status started = acquireOpenni();
  if (!started)
    return started.error();
  openni::Array<openni::DeviceInfo> infos;
  openni::OpenNI::enumerateDevices(&infos);
  std::vector<DeviceListEntry> devices;
  for (int i = 0; i < infos.getSize(); ++i)
    devices.push_back(DeviceListEntry{infos[i].getUri(), infos[i].getName(), infos[i].getVendor()});
  releaseOpenni();
  return devices;
}

// ---------------------------------------------------------------------------------------------------------------
struct OpenniDevice::Impl : public openni::OpenNI::DeviceDisconnectedListener
{
  bool openni_ready = false;
  openni::Device device;
  openni::VideoStream color;
  openni::VideoStream depth;
  bool open = false;
  bool listening = false;
  std::atomic<bool> lost{false};
  DeviceSummary summary;

  void onDeviceDisconnected(const openni::DeviceInfo* info) override
  {
    if (info != nullptr && summary.uri == info->getUri())
      lost = true;
  }

  Expected<std::string> resolve(const std::string& wanted, bool& is_file);
  Status configure(const OpenniConfig& config);
  Status createStream(StreamKind kind, const OpenniConfig& config);
  void close();
};

Expected<std::string> OpenniDevice::Impl::resolve(const std::string& wanted, bool& is_file)
{
  is_file = endsWithOni(wanted);
  if (is_file)
  {
    std::ifstream probe(wanted, std::ios::binary);
    char magic[4] = {0};
    if (!probe)
      return Error(ErrorCode::kIoError, "cannot read the recording '" + wanted + "': " + std::strerror(errno) +
                                            ". Give device_uri as an absolute path (a relative one is taken from the "
                                            "node's working directory, usually ~/.ros).");
    if (!probe.read(magic, 4) || std::string(magic, 4) != oni::kFileMagic)
      return Error(ErrorCode::kParseError, "'" + wanted +
                                               "' is not an OpenNI2 recording (it does not start with NI10): record "
                                               "one with NiViewer2 or openni::Recorder.");
    return wanted;
  }
  openni::Array<openni::DeviceInfo> infos;
  openni::OpenNI::enumerateDevices(&infos);
  std::vector<DeviceListEntry> devices;
  for (int i = 0; i < infos.getSize(); ++i)
    devices.push_back(DeviceListEntry{infos[i].getUri(), infos[i].getName(), infos[i].getVendor()});
  if (wanted.empty())
  {
    if (devices.empty())
      return Error(ErrorCode::kIoError,
                   "no OpenNI2 device is connected: plug the Xtion into a USB 2 port (lsusb should list 1d27:0600 or "
                   "1d27:0601; the udev rules of libopenni2-0 give users access), or set device_uri.");
    return devices.front().uri;
  }
  if (wanted[0] == '#')
  {
    int index = 0;
    try
    {
      index = std::stoi(wanted.substr(1));
    }
    catch (const std::exception&)
    {
      index = 0;
    }
    if (index < 1 || index > static_cast<int>(devices.size()))
      return Error(ErrorCode::kIoError, "device_uri '" + wanted + "' asks for device " + wanted.substr(1) +
                                            " but the connected devices are: " + describeDeviceList(devices) + ". " +
                                            kUriHelp);
    return devices[index - 1].uri;
  }
  for (const DeviceListEntry& entry : devices)
    if (entry.uri == wanted)
      return wanted;
  // A serial number: open each device to read its serial.
  for (const DeviceListEntry& entry : devices)
  {
    openni::Device candidate;
    if (candidate.open(entry.uri.c_str()) != openni::STATUS_OK)
      continue;
    const std::string serial = serialOf(candidate);
    candidate.close();
    if (!serial.empty() && serial == wanted)
      return entry.uri;
  }
  // Not listed: a device OpenNI2 does not enumerate (DummyDevice) or one that is not there; open() will tell.
  return wanted;
}

Status OpenniDevice::Impl::createStream(StreamKind kind, const OpenniConfig& config)
{
  const openni::SensorType sensor = kind == StreamKind::kColor ? openni::SENSOR_COLOR : openni::SENSOR_DEPTH;
  openni::VideoStream& stream = kind == StreamKind::kColor ? color : depth;
  const std::string parameter = kind == StreamKind::kColor ? "color_mode" : "depth_mode";
  const VideoModeSpec& wanted = kind == StreamKind::kColor ? config.color_mode : config.depth_mode;
  std::vector<OfferedMode>& offered = kind == StreamKind::kColor ? summary.color_modes : summary.depth_modes;

  const openni::SensorInfo* info = device.getSensorInfo(sensor);
  if (info == nullptr)
    return Error(ErrorCode::kInvalidInput, std::string(summary.is_file ? "the recording" : "the device") + " has no " +
                                               toString(kind) + " stream");
  offered = offeredModes(info, kind);
  openni::VideoMode chosen;
  bool set_mode = false;
  if (!summary.is_file)
  {
    const Expected<size_t> index = chooseMode(kind, offered, wanted, parameter);
    if (!index)
      return index.error();
    chosen = info->getSupportedVideoModes()[static_cast<int>(*index)];
    set_mode = true;
  }
  if (stream.create(device, sensor) != openni::STATUS_OK)
    return Error(ErrorCode::kIoError, std::string("cannot create the ") + toString(kind) + " stream (" +
                                          extendedError() + "): is another program using the device?");
  const openni::VideoMode current = stream.getVideoMode();
  if (set_mode && (specOf(current) != specOf(chosen) || current.getPixelFormat() != chosen.getPixelFormat()))
  {
    if (stream.setVideoMode(chosen) != openni::STATUS_OK)
      return Error(ErrorCode::kIoError, std::string("the device refused the ") + toString(kind) + " mode " +
                                            wanted.toString() + " (" + extendedError() +
                                            "); modes it offers: " + describeModes(offered));
  }
  const openni::VideoMode active = stream.getVideoMode();
  if (active.getPixelFormat() != wantedFormat(kind))
    return Error(ErrorCode::kInvalidInput, std::string("the ") + toString(kind) + " stream delivers " +
                                               pixelFormatName(active.getPixelFormat()) + ", but this driver needs " +
                                               pixelFormatName(wantedFormat(kind)));
  if (!summary.is_file)
    stream.setMirroringEnabled(false);  // not every driver has the property (DummyDevice): ignore the status
  (kind == StreamKind::kColor ? summary.color_mode : summary.depth_mode) = specOf(active);
  (kind == StreamKind::kColor ? summary.color_hfov : summary.depth_hfov) = stream.getHorizontalFieldOfView();
  (kind == StreamKind::kColor ? summary.color_vfov : summary.depth_vfov) = stream.getVerticalFieldOfView();
  return Success{};
}

Status OpenniDevice::Impl::configure(const OpenniConfig& config)
{
  for (const StreamKind kind : {StreamKind::kColor, StreamKind::kDepth})
  {
    const Status created = createStream(kind, config);
    if (!created)
      return created;
  }
  summary.registration_supported = device.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR);
  if (config.registration && summary.registration_supported && !summary.is_file)
    summary.registration_on =
        device.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) == openni::STATUS_OK;
  else if (summary.is_file)
    summary.registration_on = device.getImageRegistrationMode() == openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR;
  if (config.sync)
    summary.sync_on = device.setDepthColorSyncEnabled(true) == openni::STATUS_OK;
  if (summary.is_file)
  {
    if (openni::PlaybackControl* playback = device.getPlaybackControl())
    {
      playback->setRepeatEnabled(config.oni_loop);
      playback->setSpeed(static_cast<float>(config.oni_speed));
    }
  }
  if (color.start() != openni::STATUS_OK)
    return Error(ErrorCode::kIoError, "cannot start the colour stream (" + extendedError() + ")");
  if (depth.start() != openni::STATUS_OK)
    return Error(ErrorCode::kIoError, "cannot start the depth stream (" + extendedError() + ")");
  return Success{};
}

void OpenniDevice::Impl::close()
{
  if (listening)
  {
    openni::OpenNI::removeDeviceDisconnectedListener(this);
    listening = false;
  }
  const bool had_streams = color.isValid() || depth.isValid();
  if (color.isValid())
    color.stop();
  if (depth.isValid())
    depth.stop();
  // DummyDevice's stop() only asks its frame threads to end; they notice on their next 33 ms tick and must be gone
  // before their streams are destroyed (or the driver unloaded). Real drivers join in stop(): the wait is harmless.
  if (had_streams)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  color.destroy();
  depth.destroy();
  if (device.isValid())
    device.close();
  open = false;
}

// ---------------------------------------------------------------------------------------------------------------
OpenniDevice::OpenniDevice() : impl_(new Impl) {}

OpenniDevice::~OpenniDevice()
{
  close();
  if (impl_->openni_ready)
    releaseOpenni();
}

Status OpenniDevice::open(const OpenniConfig& config)
{
  close();
  if (!impl_->openni_ready)
  {
    const Status started = acquireOpenni();
    if (!started)
      return started;
    impl_->openni_ready = true;
  }
  Impl& d = *impl_;
  d.summary = DeviceSummary();
  d.lost = false;
  bool is_file = false;
  const Expected<std::string> uri = d.resolve(config.uri, is_file);
  if (!uri)
    return uri.error();
  if (d.device.open(uri->c_str()) != openni::STATUS_OK)
  {
    const std::string details = extendedError();
    if (is_file)
      return Error(ErrorCode::kParseError, "cannot play the recording '" + *uri + "' (OpenNI2: " + details +
                                               "): the file is damaged or not an .oni recording.");
    openni::Array<openni::DeviceInfo> infos;
    openni::OpenNI::enumerateDevices(&infos);
    std::vector<DeviceListEntry> devices;
    for (int i = 0; i < infos.getSize(); ++i)
      devices.push_back(DeviceListEntry{infos[i].getUri(), infos[i].getName(), infos[i].getVendor()});
    return Error(ErrorCode::kIoError, "cannot open device '" + (config.uri.empty() ? *uri : config.uri) +
                                          "' (OpenNI2: " + details +
                                          "). Connected devices: " + describeDeviceList(devices) + ". " + kUriHelp);
  }
  const openni::DeviceInfo& info = d.device.getDeviceInfo();
  d.summary.uri = info.getUri();
  d.summary.name = info.getName();
  d.summary.vendor = info.getVendor();
  d.summary.is_file = d.device.isFile();
  if (!d.summary.is_file)
    d.summary.serial = serialOf(d.device);
  const Status configured = d.configure(config);
  if (!configured)
  {
    d.close();
    return configured;
  }
  if (!d.summary.is_file && openni::OpenNI::addDeviceDisconnectedListener(&d) == openni::STATUS_OK)
    d.listening = true;
  d.open = true;
  return Success{};
}

bool OpenniDevice::isOpen() const
{
  return impl_->open;
}

const DeviceSummary& OpenniDevice::summary() const
{
  return impl_->summary;
}

bool OpenniDevice::disconnected() const
{
  return impl_->lost;
}

Expected<bool> OpenniDevice::readFrame(int timeout_ms, const std::function<void(const FrameView&)>& sink)
{
  Impl& d = *impl_;
  if (!d.open)
    return Error(ErrorCode::kIoError, "the device is not open");
  if (d.lost)
    return Error(ErrorCode::kIoError, "device " + d.summary.uri + " was disconnected");
  openni::VideoStream* streams[2] = {&d.color, &d.depth};
  int ready = -1;
  const openni::Status rc = openni::OpenNI::waitForAnyStream(streams, 2, &ready, timeout_ms);
  if (rc == openni::STATUS_TIME_OUT)
    return false;
  if (rc != openni::STATUS_OK || ready < 0 || ready > 1)
    return Error(ErrorCode::kIoError, "waiting for frames from " + d.summary.uri + " failed (" + extendedError() + ")");
  openni::VideoFrameRef frame;
  if (streams[ready]->readFrame(&frame) != openni::STATUS_OK || !frame.isValid())
    return Error(ErrorCode::kIoError, "reading a frame from " + d.summary.uri + " failed (" + extendedError() + ")");
  FrameView view;
  view.stream = ready == 0 ? StreamKind::kColor : StreamKind::kDepth;
  view.width = frame.getWidth();
  view.height = frame.getHeight();
  view.stride_bytes = static_cast<size_t>(frame.getStrideInBytes());
  view.device_time_us = frame.getTimestamp();
  view.frame_index = frame.getFrameIndex();
  view.data = static_cast<const uint8_t*>(frame.getData());
  const size_t row_bytes = static_cast<size_t>(view.width) * (view.stream == StreamKind::kColor ? 3 : 2);
  if (view.data == nullptr || view.stride_bytes < row_bytes ||
      static_cast<size_t>(frame.getDataSize()) < view.stride_bytes * static_cast<size_t>(view.height - 1) + row_bytes)
    return Error(ErrorCode::kIoError, std::string("a ") + toString(view.stream) + " frame from " + d.summary.uri +
                                          " is smaller than its size says; dropping it");
  if (sink)
    sink(view);
  return true;
}

void OpenniDevice::close()
{
  impl_->close();
}

Status OpenniDevice::record(const std::string& path, double seconds,
                            const std::function<void(const FrameView&)>& on_frame)
{
  Impl& d = *impl_;
  if (!d.open)
    return Error(ErrorCode::kIoError, "open the device before recording");
  {
    openni::Recorder recorder;
    if (recorder.create(path.c_str()) != openni::STATUS_OK)
      return Error(ErrorCode::kIoError, "cannot write the recording '" + path + "' (" + extendedError() + ")");
    if (recorder.attach(d.color, false) != openni::STATUS_OK || recorder.attach(d.depth, false) != openni::STATUS_OK)
      return Error(ErrorCode::kIoError, "cannot attach the streams to the recorder (" + extendedError() + ")");
    if (recorder.start() != openni::STATUS_OK)
      return Error(ErrorCode::kIoError, "cannot start the recorder (" + extendedError() + ")");
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    Status recorded = Success{};
    while (recorded && std::chrono::steady_clock::now() < end)
      if (const Expected<bool> read = readFrame(200, on_frame); !read)
        recorded = read.error();
    // OpenNI2 deadlocks when the recorder stops while a stream's frame thread is handing it a frame (seen under
    // load: each waits for the other's lock), so the streams stop first; DummyDevice's frame threads only notice on
    // their next 33 ms tick. Then the recorder, and the streams again for whoever reads next.
    d.color.stop();
    d.depth.stop();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    recorder.stop();
    recorder.destroy();  // waits until the file is complete
    if (d.color.start() != openni::STATUS_OK || d.depth.start() != openni::STATUS_OK)
      return Error(ErrorCode::kIoError, "cannot restart the streams after recording (" + extendedError() + ")");
    if (!recorded)
      return recorded;
  }
  const Expected<int> fixed = addCroppingToOniRecording(path);
  if (!fixed)
    return fixed.error();
  return Success{};
}

Status recordOni(const OpenniConfig& config, const std::string& path, double seconds,
                 const std::function<void(const FrameView&)>& on_frame)
{
  OpenniDevice device;
  const Status opened = device.open(config);
  if (!opened)
    return opened;
  return device.record(path, seconds, on_frame);
}

// ---------------------------------------------------------------------------------------------------------------
// The .oni format: oni_format.h. Property records carry {name size, name with its NUL, data size, data}.
namespace
{
using namespace oni;

uint32_t readU32(const std::string& bytes, size_t at)
{
  uint32_t value = 0;
  std::memcpy(&value, bytes.data() + at, sizeof(value));
  return value;
}

void writeU32(std::string& bytes, size_t at, uint32_t value)
{
  std::memcpy(&bytes[at], &value, sizeof(value));
}
}  // namespace

namespace
{
// Per stream node: whether it records xnCropping, and where its xnIsGenerating record starts (0: none).
struct NodeRecords
{
  bool has_cropping = false;
  size_t is_generating_at = 0;
};
using NodeTable = std::vector<std::pair<uint32_t, NodeRecords>>;

NodeRecords& nodeOf(NodeTable& nodes, uint32_t id)
{
  for (auto& entry : nodes)
    if (entry.first == id)
      return entry.second;
  nodes.emplace_back(id, NodeRecords());
  return nodes.back().second;
}

// Walks the records up to the end record, noting each node's cropping and xnIsGenerating records.
Expected<NodeTable> scanNodeRecords(const std::string& bytes, const std::string& path)
{
  NodeTable nodes;
  size_t at = kFileHeaderSize;
  while (at + kRecordHeaderSize <= bytes.size())
  {
    if (readU32(bytes, at) != kRecordMagic)
      return Error(ErrorCode::kParseError, "'" + path + "' has a damaged record at byte " + std::to_string(at));
    const uint32_t type = readU32(bytes, at + 4);
    const uint32_t id = readU32(bytes, at + 8);
    const uint64_t fields = readU32(bytes, at + 12);
    const uint64_t payload = readU32(bytes, at + 16);
    if (type == kRecordEnd)
      break;
    if (fields < kRecordHeaderSize || at + fields + payload > bytes.size())
      return Error(ErrorCode::kParseError, "'" + path + "' is truncated at byte " + std::to_string(at));
    if ((type == kRecordIntProperty || type == kRecordGeneralProperty) && fields >= kRecordHeaderSize + 4)
    {
      const uint32_t name_size = readU32(bytes, at + kRecordHeaderSize);
      if (name_size > 0 && kRecordHeaderSize + 4 + name_size <= fields)
      {
        const std::string name(bytes.data() + at + kRecordHeaderSize + 4, name_size - 1);
        if (name == "xnCropping")
          nodeOf(nodes, id).has_cropping = true;
        else if (name == "xnIsGenerating" && type == kRecordIntProperty)
          nodeOf(nodes, id).is_generating_at = at;
      }
    }
    at += fields + payload;
  }
  return nodes;
}

// Rewrites the xnIsGenerating record at `record` in place as an xnCropping record (cropping off): the two have the
// same size ("xnIsGenerating\0" + 8 bytes of value == "xnCropping\0" + 12 bytes of XnCropping {bool, 4 x uint16}).
bool replaceWithCropping(std::string& bytes, size_t record)
{
  const uint32_t fields = readU32(bytes, record + 12);
  const std::string name("xnCropping", 11);
  const size_t needed = kRecordHeaderSize + 4 + name.size() + 4 + 12;
  if (needed != fields)
    return false;
  writeU32(bytes, record + 4, kRecordGeneralProperty);
  writeU32(bytes, record + 16, 0);
  std::memset(&bytes[record + 20], 0, 8);  // undo position: none
  size_t p = record + kRecordHeaderSize;
  writeU32(bytes, p, static_cast<uint32_t>(name.size()));
  std::memcpy(&bytes[p + 4], name.data(), name.size());
  p += 4 + name.size();
  writeU32(bytes, p, 12);
  std::memset(&bytes[p + 4], 0, 12);  // cropping off
  return true;
}
}  // namespace

Expected<int> addCroppingToOniRecording(const std::string& path)
{
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in)
      return Error(ErrorCode::kIoError, "cannot read '" + path + "': " + std::strerror(errno));
    std::ostringstream buffer;
    buffer << in.rdbuf();
    bytes = buffer.str();
  }
  if (bytes.size() < kFileHeaderSize || bytes.compare(0, 4, kFileMagic) != 0)
    return Error(ErrorCode::kParseError, "'" + path + "' is not an OpenNI2 recording");
  const Expected<NodeTable> nodes = scanNodeRecords(bytes, path);
  if (!nodes)
    return nodes.error();
  int fixed = 0;
  for (const auto& entry : *nodes)
    if (!entry.second.has_cropping && entry.second.is_generating_at != 0 &&
        replaceWithCropping(bytes, entry.second.is_generating_at))
      ++fixed;
  if (fixed > 0)
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out)
      return Error(ErrorCode::kIoError, "cannot rewrite '" + path + "': " + std::strerror(errno));
  }
  return fixed;
}

}  // namespace drivers
}  // namespace insitu_calibration
