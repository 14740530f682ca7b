// Writes a synthetic OpenNI2 recording (.oni) without any device: uncompressed RGB888 colour and DEPTH_1_MM depth
// frames of a given mode, with the records OpenNI2's file player needs. For tests and benchmarks at modes
// DummyDevice does not offer (it has only 320x240), e.g. the Xtion's 640x480 at 30 Hz.
#ifndef INSITU_CALIBRATION_DRIVERS_ONI_WRITER_H
#define INSITU_CALIBRATION_DRIVERS_ONI_WRITER_H

#include <cstdint>
#include <string>

#include "insitu_calibration/drivers/openni_device.h"
#include "insitu_calibration/error.h"

namespace insitu_calibration
{
namespace drivers
{
struct SyntheticOniOptions
{
  VideoModeSpec mode{640, 480, 30};  // both streams
  int frames = 90;                   // per stream
  double hfov = 1.0226;              // recorded field of view (radians), as the Xtion reports it
  double vfov = 0.7966;
};

// Frame k (0-based) of the synthetic streams: colour is a gradient with a square moving across it; depth is a
// plane at 1.5 m + 2 mm per column with the square at 1 m and a band of no return (0) along the bottom.
uint8_t syntheticColor(const SyntheticOniOptions& options, int frame, int x, int y, int channel);
uint16_t syntheticDepth(const SyntheticOniOptions& options, int frame, int x, int y);

Status writeSyntheticOni(const std::string& path, const SyntheticOniOptions& options);

}  // namespace drivers
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_DRIVERS_ONI_WRITER_H
