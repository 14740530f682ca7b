// The .oni recording format of OpenNI2 (Source/Core/OniDataRecords.h, OniFileRecorder.cpp): one home for its
// constants, shared by the writer (oni_writer.cpp) and the recording patcher (openni_device.cpp). A 24-byte file
// header ("NI10", version, largest time stamp, largest node id), then records, each a packed header {magic "NIR\0",
// type, node id, fields size (header included), payload size, undo position (64 bit)} and its fields.
#ifndef INSITU_CALIBRATION_DRIVERS_ONI_FORMAT_H
#define INSITU_CALIBRATION_DRIVERS_ONI_FORMAT_H

#include <cstddef>
#include <cstdint>

namespace insitu_calibration
{
namespace drivers
{
namespace oni
{
constexpr char kFileMagic[] = "NI10";
constexpr size_t kFileHeaderSize = 24;
constexpr size_t kRecordHeaderSize = 28;
constexpr uint32_t kRecordMagic = 0x0052494E;  // "NIR\0"

// Record types.
constexpr uint32_t kRecordIntProperty = 3;
constexpr uint32_t kRecordGeneralProperty = 6;
constexpr uint32_t kRecordNodeDataBegin = 8;
constexpr uint32_t kRecordNodeStateReady = 9;
constexpr uint32_t kRecordNewData = 10;
constexpr uint32_t kRecordEnd = 11;
constexpr uint32_t kRecordNodeAdded = 13;

constexpr uint32_t kNodeTypeDepth = 2;
constexpr uint32_t kNodeTypeImage = 3;
constexpr uint32_t kCodecNone = 0x454E4F4E;  // "NONE": uncompressed
constexpr uint64_t kPixelFormatRgb24 = 1;    // OpenNI 1 names
constexpr uint64_t kPixelFormatGray16 = 4;
constexpr uint64_t kOniPixelFormatDepth1mm = 100;
constexpr uint64_t kOniPixelFormatRgb888 = 200;
}  // namespace oni
}  // namespace drivers
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_DRIVERS_ONI_FORMAT_H
