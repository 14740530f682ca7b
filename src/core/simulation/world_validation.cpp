// The limits of a world file and the guard around its reader (world.cpp reads the entries).
#include <cmath>
#include <cstdio>

#include "insitu_calibration/simulation/world_limits.h"
#include "io/yaml_util.h"

namespace insitu_calibration
{
namespace simulation
{
namespace
{
using namespace world_limits;

Error refuse(const std::string& where, const std::string& what)
{
  return Error(ErrorCode::kInvalidInput, where + ": " + what);
}

template <typename Derived>
bool withinBuilding(const Eigen::MatrixBase<Derived>& x)
{
  return x.allFinite() && x.cwiseAbs().maxCoeff() <= kMaxCoordinateM;
}

// Numbers in messages as people write them (1e+04, 0.001).
std::string num(double value)
{
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

bool within(double value, double low, double high)
{
  return std::isfinite(value) && value >= low && value <= high;
}

std::string range(double low, double high)
{
  return "must be within " + num(low) + " .. " + num(high);
}

// Materials: joints of kMinJointM .. half a unit; the structure's amounts 0..1.
Status checkStructure(const Texture& t, const std::string& where)
{
  if (t.material() && !within(t.joint, kMinJointM, 0.5 * t.cell.minCoeff()))
    return refuse(where + ".joint", range(kMinJointM, 0.5 * t.cell.minCoeff()) + " m (half the smaller cell side)");
  const std::pair<const char*, double> amounts[] = {{"variation", t.variation},
                                                    {"grain", t.grain},
                                                    {"speckle", t.speckle},
                                                    {"gradient", t.gradient},
                                                    {"shine", t.shine}};
  for (const auto& [key, value] : amounts)
    if (!within(value, 0.0, 1.0))
      return refuse(where + "." + key, range(0.0, 1.0));
  return Success{};
}

Status checkSurfaces(const World& world, const std::string& source)
{
  if (world.surfaces.size() > kMaxSurfaces)
    return refuse(source + ": surfaces", std::to_string(world.surfaces.size()) + " faces, more than the " +
                                             std::to_string(kMaxSurfaces) + " allowed");
  size_t total = 0;
  for (const Surface& s : world.surfaces)
  {
    const std::string where = source + ": surface '" + s.name + "'";
    for (const auto& ring : s.rings)
    {
      total += ring.size();
      if (ring.size() > kMaxRingVertices)
        return refuse(where, std::to_string(ring.size()) + " vertices in a ring, more than the " +
                                 std::to_string(kMaxRingVertices) + " allowed");
      for (const auto& vertex : ring)
        if (!withinBuilding(vertex))
          return refuse(where, "a vertex lies beyond " + num(kMaxCoordinateM) + " m or is not finite");
    }
    const Texture& t = s.texture;
    if (!(t.cell.minCoeff() >= kMinTextureCellM) || !withinBuilding(t.cell) || !withinBuilding(t.offset))
      return refuse(where + ".texture",
                    "cell sizes must be " + num(kMinTextureCellM) + " m or more and offsets within the building");
    if (const Status st = checkStructure(t, where + ".texture"); !st)
      return st;
    for (const auto& rect : t.rects)
      if (!withinBuilding(rect.min) || !withinBuilding(rect.max))
        return refuse(where + ".texture.rects", "a rectangle lies beyond the building");
    if (!s.normal.allFinite() || !std::isfinite(s.offset) || !s.origin.allFinite())
      return refuse(where, "its plane is not finite");
  }
  if (total > kMaxTotalVertices)
    return refuse(source + ": surfaces", std::to_string(total) + " vertices in all, more than the " +
                                             std::to_string(kMaxTotalVertices) + " allowed");
  return Success{};
}

Status checkRoute(const Route& route, const std::string& where)
{
  if (route.waypoints.size() > kMaxWaypoints)
    return refuse(where, "more than " + std::to_string(kMaxWaypoints) + " waypoints");
  for (const auto& p : route.waypoints)
    if (!withinBuilding(p))
      return refuse(where + ".waypoints", "a waypoint lies beyond " + num(kMaxCoordinateM) + " m");
  if (!within(route.speed, 1e-3, kMaxSpeedMps))
    return refuse(where + ".speed", range(1e-3, kMaxSpeedMps) + " m/s");
  if (!within(route.turn_rate_deg, 1e-2, kMaxTurnRateDegPerS))
    return refuse(where + ".turn_rate_deg", range(1e-2, kMaxTurnRateDegPerS));
  return Success{};
}

Status checkImage(int width, int height, const Intrinsics& in, const std::string& where)
{
  if (width < kMinImageSide || height < kMinImageSide || width > kMaxImageSide || height > kMaxImageSide)
    return refuse(where, "width and height must be within " + std::to_string(kMinImageSide) + " .. " +
                             std::to_string(kMaxImageSide) + " px (got " + std::to_string(width) + "x" +
                             std::to_string(height) + ")");
  if (!within(in.fx, 1e-3, kMaxFocalPx) || !within(in.fy, 1e-3, kMaxFocalPx) || !within(in.skew, -in.fx, in.fx))
    return refuse(where, "fx and fy " + range(1e-3, kMaxFocalPx) + " and |skew| below fx");
  if (!within(in.cx, -width, 2.0 * width) || !within(in.cy, -height, 2.0 * height))
    return refuse(where, "the principal point must lie within one image size of the image");
  return Success{};
}

Status checkXtion(const XtionConfig& x, const std::string& where)
{
  if (const Status s = checkImage(x.width, x.height, x.intrinsics, where); !s)
    return s;
  if (!within(x.mount_height_m, 0.0, 100.0) || !within(x.mount_forward_m, -100.0, 100.0) ||
      !withinBuilding(x.rgb_offset) || !withinBuilding(x.depth_offset))
    return refuse(where, "the mount height and offsets must be finite and within 100 m");
  const DepthSensorConfig& d = x.depth;
  if (!within(x.rgb_noise_sigma, 0.0, kMaxNoise) || !within(d.sigma_coefficient, 0.0, 1.0) ||
      !within(d.baseline_m, 1e-4, 10.0) || !within(d.disparity_subpixel, 0.0, 1024.0) ||
      !within(d.correlation_px, 0.0, x.width))
    return refuse(where, "rgb_noise_sigma " + range(0, kMaxNoise) + ", depth.sigma_coefficient " + range(0, 1) +
                             ", depth.baseline " + range(1e-4, 10) + ", depth.disparity_subpixel " + range(0, 1024) +
                             ", depth.correlation_px at most the width");
  return Success{};
}

Status checkCameraAppearance(const CameraAppearance& a, const std::string& where)
{
  if (!within(a.blur_sigma_px, 0.0, kMaxBlurSigmaPx))
    return refuse(where + ".blur_sigma_px", range(0.0, kMaxBlurSigmaPx));
  if (!within(a.vignetting, 0.0, 1.0))
    return refuse(where + ".vignetting", range(0.0, 1.0));
  if (!within(a.exposure, kMinGain, kMaxGain))
    return refuse(where + ".exposure", range(kMinGain, kMaxGain));
  for (int k = 0; k < 3; ++k)
    if (!within(a.white_balance[k], kMinGain, kMaxGain))
      return refuse(where + ".white_balance", "each gain " + range(kMinGain, kMaxGain));
  if (a.jpeg_quality < 0 || a.jpeg_quality > 100)
    return refuse(where + ".jpeg_quality", "must be within 1 .. 100, or 0 for no compression");
  return Success{};
}

Status checkAppearance(const Appearance& a, int xtion_width, const std::string& where)
{
  if (const Status s = checkCameraAppearance(a.xtion_rgb, where + ".xtion_rgb"); !s)
    return s;
  if (const Status s = checkCameraAppearance(a.fixed_cameras, where + ".fixed_cameras"); !s)
    return s;
  const DepthAppearance& d = a.depth;
  if (!within(d.flying_pixels, 0.0, 1.0))
    return refuse(where + ".depth.flying_pixels", range(0.0, 1.0));
  if (!within(d.flying_step_m, 1e-3, 10.0))
    return refuse(where + ".depth.flying_step_m", range(1e-3, 10.0) + " m");
  if (!within(d.low_frequency_coefficient, 0.0, 1.0))
    return refuse(where + ".depth.low_frequency_coefficient", range(0.0, 1.0));
  if (!within(d.low_frequency_px, kMinLowFrequencyPx, xtion_width))
    return refuse(where + ".depth.low_frequency_px", range(kMinLowFrequencyPx, xtion_width) + " (the Xtion's width)");
  if (!d.misregistration_px.allFinite() || d.misregistration_px.cwiseAbs().maxCoeff() > kMaxMisregistrationPx)
    return refuse(where + ".depth.misregistration_px",
                  "each axis " + range(-kMaxMisregistrationPx, kMaxMisregistrationPx));
  return Success{};
}

Status checkFixedCameras(const World& world, const std::string& source)
{
  if (world.fixed_cameras.size() > kMaxFixedCameras)
    return refuse(source + ": fixed_cameras", "more than " + std::to_string(kMaxFixedCameras) + " cameras");
  for (const SimulatedFixedCamera& c : world.fixed_cameras)
  {
    const std::string where = source + ": fixed camera '" + c.name + "'";
    if (const Status s = checkImage(c.width, c.height, c.camera.intrinsics(), where); !s)
      return s;
    if (!std::isfinite(c.camera.distortion().lambda) || !c.camera.distortion().center.allFinite())
      return refuse(where, "the distortion must be finite");
    if (!withinBuilding(c.camera.pose().center()) || !c.camera.pose().worldFromCamera().matrix().allFinite())
      return refuse(where + ".position", "must lie within " + num(kMaxCoordinateM) + " m");
    if (!within(c.rate_hz, kMinRateHz, kMaxRateHz))
      return refuse(where + ".rate", range(kMinRateHz, kMaxRateHz) + " Hz");
    if (!within(c.phase_s, 0.0, kMaxPhaseS))
      return refuse(where + ".phase", range(0.0, kMaxPhaseS) + " s");
    if (!within(c.noise.read_sigma, 0.0, kMaxNoise) || !within(c.noise.shot_gain, 0.0, kMaxNoise))
      return refuse(where + ".noise", range(0.0, kMaxNoise));
    if (const Status s = checkCameraAppearance(c.appearance, where + ".appearance"); !s)
      return s;
  }
  return Success{};
}
}  // namespace

Status validateWorldLimits(const World& world, const std::string& source)
{
  if (const Status s = checkSurfaces(world, source); !s)
    return s;
  if (const Status s = checkRoute(world.route, source + ": route"); !s)
    return s;
  if (const Status s = checkXtion(world.xtion, source + ": xtion"); !s)
    return s;
  if (!world.lighting.direction.allFinite() || !std::isfinite(world.lighting.ambient) ||
      !std::isfinite(world.lighting.diffuse))
    return refuse(source + ": lighting", "NaN or infinite values");
  if (const Status s = checkAppearance(world.appearance, world.xtion.width, source + ": appearance"); !s)
    return s;
  return checkFixedCameras(world, source);
}

Expected<World> parseWorld(const std::string& yaml_text, const std::string& source)
{
  auto world = yaml_util::guarded<World>(source, [&] { return parseWorldEntries(yaml_text, source); });
  if (!world)
    return world.error();
  if (const Status valid = validateWorldLimits(*world, source); !valid)
    return valid.error();
  return world;
}

}  // namespace simulation
}  // namespace insitu_calibration
