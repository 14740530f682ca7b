// The simulated building: textured planar polygons, the robot's route and its Xtion, and the fixed cameras, as read
// from a world file (YAML, config/worlds/*.yaml; the format is documented in docs/simulator.md).
//
// Every shape of the file (polygon, rectangle, box, wall) becomes one or more Surfaces: a planar polygon (an
// outline and optional holes, filled by the even-odd rule, seen from both sides) with a texture frame (origin, u and
// v axes in its plane, metres) and a procedural texture with strong edges (solid, checker, stripes, and the materials
// planks, bricks and tiles with their joints, plus rectangles on top: poster pictures, door panels, window frames),
// optionally with natural structure inside its regions (grain, speckle, a lighting gradient, a glossy highlight).
#ifndef INSITU_CALIBRATION_SIMULATION_WORLD_H
#define INSITU_CALIBRATION_SIMULATION_WORLD_H

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"

namespace insitu_calibration
{
namespace simulation
{
using Color = Eigen::Vector3f;  // RGB, 0..255

struct TextureRect
{
  Eigen::Vector2d min = Eigen::Vector2d::Zero();  // in the surface's (u, v) frame, metres
  Eigen::Vector2d max = Eigen::Vector2d::Zero();
  Color color = Color::Zero();
};

struct Texture
{
  enum class Pattern
  {
    kSolid,
    kChecker,
    kStripes,
    kPlanks,  // boards of cell (length along u, width along v) in rows along u, each row's joints at a random offset
    kBricks,  // bricks of cell (length along u, height along v) in courses along u, every other one shifted by half
    kTiles    // a grid of cell tiles
  };
  Pattern pattern = Pattern::kSolid;
  Color color = Color(200.0f, 200.0f, 200.0f);       // solid colour; first colour of checker and stripes
  Color color2 = Color(80.0f, 80.0f, 80.0f);         // second colour of checker and stripes
  Eigen::Vector2d cell = Eigen::Vector2d(0.5, 0.5);  // checker: cell size in u, v; stripes: widths of the 2 bands
  bool stripes_along_v = false;                      // stripes: bands stacked along v (horizontal) instead of u
  Eigen::Vector2d offset = Eigen::Vector2d::Zero();  // origin of the pattern in (u, v)
  std::vector<TextureRect> rects;                    // painted in order over the pattern (the last on top)
  // Materials (planks, bricks, tiles): color is the units', color2 the joints' (mortar, grout, gaps) of this width.
  double joint = 0.004;
  // Natural structure, 0..1 each; changes brightness inside regions only (the edges stay where the regions change).
  double variation = 0.0;  // materials: each unit's brightness differs by up to this
  double grain = 0.0;      // wood grain: wavy streaks along u
  double speckle = 0.0;    // fine noise on 3 mm cells (carpet, brick, fabric, concrete)
  double gradient = 0.0;   // brightness varying smoothly over metres (paint under uneven light); also on rects
  double shine = 0.0;      // a glossy highlight of the light (Blinn-Phong, exponent 40), up to this x 255 grey levels
  uint32_t seed = 0;       // of the variation, grain, speckle and gradient

  bool material() const
  {
    return pattern == Pattern::kPlanks || pattern == Pattern::kBricks || pattern == Pattern::kTiles;
  }

  // Colour at (u, v) and the region it belongs to: every change of region is a strong edge (the pattern's parity, a
  // material's unit 0 or joint 1, or 2 + the index of the top rectangle).
  Color sample(double u, double v, int* region) const;
  // The base pattern alone (no rectangles).
  Color basePattern(double u, double v, int* region) const;
  // A material's unit or joint at (u, v) relative to offset: region 0 (unit, its index in *unit) or 1 (joint).
  int materialRegion(double u, double v, Eigen::Vector2i* unit) const;
  // Materials: the u offset of row j's joints (bricks: half a brick every other course; planks: random).
  double rowShift(long row) const;
  // The brightness factor of the natural structure at (u, v) in the given region (1 without structure).
  float structure(double u, double v, int region) const;
};

struct Surface
{
  std::string name;
  std::vector<std::vector<Eigen::Vector3d>> rings;  // rings[0]: the outline; more rings: holes (even-odd rule)
  Texture texture;

  // Derived by finalizeSurface(): the plane normal . X = offset, the texture frame and the rings in it.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double offset = 0.0;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d axis_v = Eigen::Vector3d::UnitY();
  std::vector<std::vector<Eigen::Vector2d>> rings_uv;

  Eigen::Vector2d toSurface(const Eigen::Vector3d& world) const
  {
    const Eigen::Vector3d d = world - origin;
    return {axis_u.dot(d), axis_v.dot(d)};
  }
  Eigen::Vector3d toWorld(const Eigen::Vector2d& uv) const { return origin + uv.x() * axis_u + uv.y() * axis_v; }
  // Even-odd point-in-polygon test in the surface frame.
  bool contains(const Eigen::Vector2d& uv) const;
  // Distance from a world point to the polygon (its plane inside it, its boundary outside).
  double distance(const Eigen::Vector3d& world) const;
};

// Validates the rings (>= 3 vertices each, planar within 1 mm, non-zero area) and derives the plane and the ring
// coordinates. The texture frame is the first edge of the outline unless set (axis_u non-zero and in the plane)
// by the caller with set_frame = true.
Status finalizeSurface(Surface& surface, bool set_frame = false);

struct Lighting
{
  double ambient = 0.6;  // shade = ambient + diffuse |n . direction|, constant over each surface
  double diffuse = 0.4;
  Eigen::Vector3d direction = Eigen::Vector3d(0.3, 0.5, 1.0).normalized();  // towards the light
};

struct Route
{
  std::vector<Eigen::Vector2d> waypoints;  // on the floor, map frame
  double speed = 0.35;                     // m/s along straight legs
  double turn_rate_deg = 30.0;             // deg/s, turning in place at the waypoints
  bool loop = true;                        // back to the first waypoint and around again; else stop at the last
};

// The Xtion's depth sensor: Gaussian axial noise in disparity so that with the disparity quantisation the depth
// error has sigma_coefficient * z^2 (Khoshelham and Elberink 2012); then millimetres, 0 for no return.
struct DepthSensorConfig
{
  double sigma_coefficient = 1.4e-3;  // 1/m: sigma_z = coefficient * z^2
  double baseline_m = 0.075;          // projector-camera baseline (disparity = f b / z)
  double disparity_subpixel = 8.0;    // disparity quantised to 1/subpixel px (0: no quantisation)
  double min_range_m = 0.5;
  double max_range_m = 5.0;
  double max_incidence_deg = 75.0;  // no return at more grazing angles
  double correlation_px = 0.0;      // noise correlation length (0: independent pixels)
};

struct XtionConfig
{
  int width = 640;
  int height = 480;
  Intrinsics intrinsics{570.3422241210938, 570.3422241210938, 0.0, 319.5, 239.5};  // openni2's defaults at VGA
  double mount_height_m = 1.1;                                      // camera_link above base_link (the floor)
  double mount_forward_m = 0.1;                                     // camera_link ahead of base_link
  double tilt_deg = 10.0;                                           // pitch of camera_link, positive looking up
  Eigen::Vector3d rgb_offset = Eigen::Vector3d(0.0, -0.045, 0.0);   // camera_link -> camera_rgb_frame (openni2)
  Eigen::Vector3d depth_offset = Eigen::Vector3d(0.0, -0.02, 0.0);  // camera_link -> camera_depth_frame
  DepthSensorConfig depth;
  double rgb_noise_sigma = 0.0;  // grey levels, 0 = none
  int supersampling = 3;         // anti-aliasing: n x n samples in pixels on edges
};

struct ImageNoiseConfig
{
  double read_sigma = 1.5;  // grey levels
  double shot_gain = 0.02;  // variance grows by shot_gain per grey level: sigma^2 = read^2 + gain I
};

// A colour camera's optics and image processing (the world file's appearance block, docs/simulator.md). The defaults
// change nothing; every effect is off at its neutral value.
struct CameraAppearance
{
  double blur_sigma_px = 0.0;  // Gaussian point-spread function, pixels (0: sharp)
  double vignetting = 0.0;  // 0..1: brightness times 1 - vignetting (1 - cos^4 theta), theta the ray's angle off axis
  double exposure = 1.0;    // gain on all channels (values saturate at 255)
  Eigen::Vector3d white_balance = Eigen::Vector3d::Ones();  // gains on R, G, B
  int jpeg_quality = 0;  // 1..100: each frame compressed to JPEG at this quality and decoded; 0: none

  bool neutral() const
  {
    return blur_sigma_px == 0.0 && vignetting == 0.0 && exposure == 1.0 && white_balance == Eigen::Vector3d::Ones() &&
           jpeg_quality == 0;
  }
};

// The Xtion's registered depth beyond its noise model (DepthSensorConfig). Neutral by default.
struct DepthAppearance
{
  double flying_pixels = 0.0;   // 0..1: share of the pixels at a depth step that take a depth between its two sides
  double flying_step_m = 0.05;  // a step: 4-neighbours further apart in depth than this (+ 2 % of the depth)
  double low_frequency_coefficient = 0.0;  // 1/m: a smooth error field with sigma coefficient * z^2
  double low_frequency_px = 60.0;          // its correlation length, pixels
  Eigen::Vector2d misregistration_px = Eigen::Vector2d::Zero();  // depth registered this far off the RGB image
};

struct Appearance
{
  CameraAppearance xtion_rgb;
  DepthAppearance depth;
  CameraAppearance fixed_cameras;  // every fixed camera's unless it has its own appearance block
};

struct SimulatedFixedCamera
{
  std::string name;
  int width = 0;
  int height = 0;
  CameraModel camera;  // true K, division model and pose (world = map)
  double rate_hz = 0.2;
  double phase_s = 0.0;  // first frame at start + phase
  ImageNoiseConfig noise;
  CameraAppearance appearance;
  int supersampling = 4;
};

struct World
{
  std::string name;
  std::string source;  // the file it came from
  std::vector<Surface> surfaces;
  Lighting lighting;
  Appearance appearance;
  Route route;
  XtionConfig xtion;
  std::vector<SimulatedFixedCamera> fixed_cameras;
};

// Typed errors name the problem and where it is, e.g.
//   "waiting_room.yaml: surfaces[4] 'table': polygon has 2 vertices, at least 3 are needed".
Expected<World> parseWorld(const std::string& yaml_text, const std::string& source = "world");
Expected<World> loadWorldFile(const std::string& path);

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_WORLD_H
