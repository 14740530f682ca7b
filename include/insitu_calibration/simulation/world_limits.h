// The documented limits of a world file (docs/simulator.md, "World file format"): what the simulator can render in
// bounded time and memory. parseWorld checks them after reading, before anything is sized from them (images, frames,
// samples).
#ifndef INSITU_CALIBRATION_SIMULATION_WORLD_LIMITS_H
#define INSITU_CALIBRATION_SIMULATION_WORLD_LIMITS_H

#include <cstddef>
#include <string>

#include "insitu_calibration/error.h"
#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace simulation
{
namespace world_limits
{
constexpr double kMaxCoordinateM = 1e4;      // |x|, |y|, |z| of every vertex, waypoint and camera position
constexpr size_t kMaxSurfaces = 5000;        // after boxes and walls are split into faces
constexpr size_t kMaxRingVertices = 1000;    // per outline or hole
constexpr size_t kMaxTotalVertices = 50000;  // over every surface
constexpr double kMinTextureCellM = 1e-3;    // checker cells and stripes, metres
constexpr double kMinJointM = 2e-3;          // planks', bricks' and tiles' joints (true edges test 1 mm either side)
constexpr size_t kMaxWaypoints = 10000;
constexpr double kMaxSpeedMps = 10.0;
constexpr double kMaxTurnRateDegPerS = 3600.0;
constexpr int kMinImageSide = 16;
constexpr int kMaxImageSide = 4096;  // px, the Xtion's and every fixed camera's width and height
constexpr double kMaxFocalPx = 1e5;
constexpr size_t kMaxFixedCameras = 64;
constexpr double kMinRateHz = 1e-3;  // fixed cameras' frame rate
constexpr double kMaxRateHz = 100.0;
constexpr double kMaxPhaseS = 1e4;
constexpr double kMaxNoise = 1e3;         // grey levels (sigmas, gains)
constexpr double kMaxBlurSigmaPx = 10.0;  // appearance: the blur kernel is 6 sigma wide
constexpr double kMinGain = 0.05;         // appearance: exposure and white-balance gains
constexpr double kMaxGain = 10.0;
constexpr double kMaxMisregistrationPx = 10.0;  // appearance.depth.misregistration_px, each axis
constexpr double kMinLowFrequencyPx = 2.0;      // appearance.depth.low_frequency_px (grid of width / this nodes)
}  // namespace world_limits

// Refuses a world beyond the limits above or with a non-finite number, naming the entry.
Status validateWorldLimits(const World& world, const std::string& source);

// parseWorld without the guard and the limits (world.cpp); parseWorld = guarded(parseWorldEntries) + limits.
Expected<World> parseWorldEntries(const std::string& yaml_text, const std::string& source);

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_WORLD_LIMITS_H
