#include "insitu_calibration/drivers/oni_writer.h"

#include "drivers/oni_format.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <vector>

namespace insitu_calibration
{
namespace drivers
{
namespace
{
using namespace oni;  // the format's constants (oni_format.h)

class RecordBuffer
{
public:
  void begin(uint32_t type, uint32_t node)
  {
    record_.clear();
    put32(kRecordMagic);
    put32(type);
    put32(node);
    put32(0);  // fields size, set by finish()
    put32(0);  // payload size
    put64(0);  // undo position
  }
  void put32(uint32_t value) { putBytes(&value, sizeof(value)); }
  void put64(uint64_t value) { putBytes(&value, sizeof(value)); }
  void putBytes(const void* data, size_t size)
  {
    const auto* bytes = static_cast<const uint8_t*>(data);
    record_.insert(record_.end(), bytes, bytes + size);
  }
  void putString(const std::string& text)
  {
    put32(static_cast<uint32_t>(text.size() + 1));
    putBytes(text.c_str(), text.size() + 1);
  }
  // Writes the record; `payload` (frame data) follows the fields.
  void finish(std::ofstream& out, const std::vector<uint8_t>& payload = {})
  {
    const uint32_t fields = static_cast<uint32_t>(record_.size());
    const uint32_t payload_size = static_cast<uint32_t>(payload.size());
    std::memcpy(&record_[12], &fields, 4);
    std::memcpy(&record_[16], &payload_size, 4);
    out.write(reinterpret_cast<const char*>(record_.data()), static_cast<std::streamsize>(record_.size()));
    if (!payload.empty())
      out.write(reinterpret_cast<const char*>(payload.data()), static_cast<std::streamsize>(payload.size()));
  }

private:
  std::vector<uint8_t> record_;
};

void intProperty(RecordBuffer& r, std::ofstream& out, uint32_t node, const std::string& name, uint64_t value)
{
  r.begin(kRecordIntProperty, node);
  r.putString(name);
  r.put32(sizeof(value));
  r.put64(value);
  r.finish(out);
}

void generalProperty(RecordBuffer& r, std::ofstream& out, uint32_t node, const std::string& name, const void* data,
                     uint32_t size)
{
  r.begin(kRecordGeneralProperty, node);
  r.putString(name);
  r.put32(size);
  r.putBytes(data, size);
  r.finish(out);
}
}  // namespace

uint8_t syntheticColor(const SyntheticOniOptions& options, int frame, int x, int y, int channel)
{
  const int w = options.mode.width;
  const int h = options.mode.height;
  const int side = h / 4;
  const int left = (frame * 8) % std::max(1, w - side);
  const int top = h / 3;
  if (x >= left && x < left + side && y >= top && y < top + side)
    return channel == 0 ? 255 : (channel == 1 ? 64 : 0);
  return static_cast<uint8_t>(channel == 0 ? 255 * x / w : (channel == 1 ? 255 * y / h : 128));
}

uint16_t syntheticDepth(const SyntheticOniOptions& options, int frame, int x, int y)
{
  const int w = options.mode.width;
  const int h = options.mode.height;
  if (y >= h - h / 16)
    return 0;
  const int side = h / 4;
  const int left = (frame * 8) % std::max(1, w - side);
  const int top = h / 3;
  if (x >= left && x < left + side && y >= top && y < top + side)
    return 1000;
  return static_cast<uint16_t>(1500 + 2 * x);
}

namespace
{
constexpr uint32_t kColorNode = 1;
constexpr uint32_t kDepthNode = 2;

// File header: "NI10", version 1.0.1.0, the largest time stamp, the largest node id.
void writeFileHeader(std::ofstream& out, uint64_t last_us)
{
  out.write(kFileMagic, 4);
  const uint8_t version[8] = {1, 0, 1, 0, 0, 0, 0, 0};
  out.write(reinterpret_cast<const char*>(version), sizeof(version));
  out.write(reinterpret_cast<const char*>(&last_us), sizeof(last_us));
  const uint32_t max_node = 2;
  out.write(reinterpret_cast<const char*>(&max_node), sizeof(max_node));
}

// A stream's node: its record and the properties OpenNI2's player reads (mode, pixel format, field of view).
void writeNode(RecordBuffer& r, std::ofstream& out, uint32_t node, const SyntheticOniOptions& options, uint64_t last_us)
{
  const VideoModeSpec& mode = options.mode;
  const bool color = node == kColorNode;
  const uint32_t bytes_per_pixel = color ? 3 : 2;
  r.begin(kRecordNodeAdded, node);
  r.putString(color ? "Image" : "Depth");
  r.put32(color ? kNodeTypeImage : kNodeTypeDepth);
  r.put32(kCodecNone);
  r.put32(static_cast<uint32_t>(options.frames));
  r.put64(0);        // first time stamp
  r.put64(last_us);  // last time stamp
  r.put64(0);        // no seek table
  r.finish(out);
  intProperty(r, out, node, "oniRequiredFrameSize", static_cast<uint64_t>(mode.width) * mode.height * bytes_per_pixel);
  const uint8_t cropping[12] = {0};  // XnCropping {bool enabled, 4 x uint16}: off
  generalProperty(r, out, node, "xnCropping", cropping, sizeof(cropping));
  if (!color)
    intProperty(r, out, node, "xnDeviceMaxDepth", 10000);
  intProperty(r, out, node, "xnSupportedMapOutputModesCount", 1);
  const uint32_t map_mode[3] = {static_cast<uint32_t>(mode.width), static_cast<uint32_t>(mode.height),
                                static_cast<uint32_t>(mode.fps)};
  generalProperty(r, out, node, "xnSupportedMapOutputModes", map_mode, sizeof(map_mode));
  generalProperty(r, out, node, "xnMapOutputMode", map_mode, sizeof(map_mode));
  const uint32_t supported_formats = color ? 1u : 8u;  // bit field: RGB24 / Grayscale16
  generalProperty(r, out, node, "xnSupportedPixelFormats", &supported_formats, sizeof(supported_formats));
  intProperty(r, out, node, "xnPixelFormat", color ? kPixelFormatRgb24 : kPixelFormatGray16);
  intProperty(r, out, node, "oniPixelFormat", color ? kOniPixelFormatRgb888 : kOniPixelFormatDepth1mm);
  const double fov[2] = {options.hfov, options.vfov};
  generalProperty(r, out, node, "xnFOV", fov, sizeof(fov));
}

// Every frame of both streams, generated by syntheticColor and syntheticDepth.
void writeFrames(RecordBuffer& r, std::ofstream& out, const SyntheticOniOptions& options, uint64_t period_us)
{
  const VideoModeSpec& mode = options.mode;
  std::vector<uint8_t> color_data(static_cast<size_t>(mode.width) * mode.height * 3);
  std::vector<uint8_t> depth_data(static_cast<size_t>(mode.width) * mode.height * 2);
  for (int k = 0; k < options.frames; ++k)
  {
    for (int y = 0; y < mode.height; ++y)
      for (int x = 0; x < mode.width; ++x)
      {
        const size_t i = static_cast<size_t>(y) * mode.width + x;
        for (int c = 0; c < 3; ++c)
          color_data[3 * i + c] = syntheticColor(options, k, x, y, c);
        const uint16_t d = syntheticDepth(options, k, x, y);
        std::memcpy(&depth_data[2 * i], &d, 2);
      }
    for (const uint32_t node : {kColorNode, kDepthNode})
    {
      r.begin(kRecordNewData, node);
      r.put64(period_us * k);                 // time stamp
      r.put32(static_cast<uint32_t>(k + 1));  // frame id
      r.finish(out, node == kColorNode ? color_data : depth_data);
    }
  }
}
}  // namespace

Status writeSyntheticOni(const std::string& path, const SyntheticOniOptions& options)
{
  const VideoModeSpec& mode = options.mode;
  if (mode.width <= 0 || mode.height <= 0 || mode.fps <= 0 || options.frames <= 0)
    return Error(ErrorCode::kInvalidInput, "a synthetic recording needs a mode and at least one frame");
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    return Error(ErrorCode::kIoError, "cannot write '" + path + "': " + std::strerror(errno));
  const uint64_t period_us = 1000000 / mode.fps;
  const uint64_t last_us = period_us * (options.frames - 1);
  writeFileHeader(out, last_us);
  RecordBuffer r;
  for (const uint32_t node : {kColorNode, kDepthNode})
    writeNode(r, out, node, options, last_us);
  for (const uint32_t node : {kColorNode, kDepthNode})
  {
    r.begin(kRecordNodeStateReady, node);
    r.finish(out);
    r.begin(kRecordNodeDataBegin, node);
    r.put32(static_cast<uint32_t>(options.frames));
    r.put64(last_us);
    r.finish(out);
  }
  writeFrames(r, out, options, period_us);
  r.begin(kRecordEnd, 0);
  r.finish(out);
  out.close();
  if (!out)
    return Error(ErrorCode::kIoError, "writing '" + path + "' failed: " + std::strerror(errno));
  return Success{};
}

}  // namespace drivers
}  // namespace insitu_calibration
