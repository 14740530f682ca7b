// A small ray-cast renderer of scenes made of flat-shaded planar quads, with known straight 3D edges: the ground
// truth of the line-extraction tests and of bench_lines until the survey simulator is available. Images are
// anti-aliased by supersampling the pixels on a boundary (Halton offsets, so an axis-aligned edge is resolved to
// 1/supersamples px), through any CameraModel (division-model distortion included). Depth is the optical-frame z of
// the surface under each pixel centre, optionally with the Kinect/Xtion noise model sigma_z = k z^2
// (Khoshelham & Elberink 2012: k = 1.425e-3 / m) and millimetre quantisation.
#ifndef INSITU_CALIBRATION_SYNTHETIC_LINE_SCENE_H
#define INSITU_CALIBRATION_SYNTHETIC_LINE_SCENE_H

#include <random>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/synthetic/synthetic_lines.h"

namespace insitu_calibration
{
// The parallelogram origin + a u + b v, a, b in [0, 1], of one grey level (0..255).
struct SceneQuad
{
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d v = Eigen::Vector3d::UnitY();
  double grey = 128.0;
};

struct LineScene
{
  std::vector<SceneQuad> quads;
  double background_grey = 0.0;  // where a ray hits nothing

  // The four edges of every quad (duplicates where quads share an edge).
  std::vector<Segment3d> edges() const;
  // Nearest hit along a ray (camera centre, unit direction): distance along the ray, quad index; -1 if none.
  int intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double* distance) const;
};

// A 6 x 5 x 2.7 m room (z up, floor at z = 0) with doors, posters and boxes on the floor: edges of contrast at
// many directions, and depth discontinuities at the boxes. Greys vary with the seed.
LineScene makeRoomScene(std::mt19937& rng);

struct RenderOptions
{
  int supersamples = 64;       // per boundary pixel (1: no anti-aliasing)
  double noise_sigma = 2.0;    // grey levels, Gaussian, added to every pixel
  double blur_sigma_px = 0.0;  // optical blur (Gaussian) before the noise
};

// 8UC1 grey image through the camera (pose = world to camera). Pixels whose ray misses every quad take the
// background grey.
cv::Mat renderGrey(const LineScene& scene, const CameraModel& camera, int width, int height,
                   const RenderOptions& options, std::mt19937& rng);

// 32FC1 depth in metres (optical-frame z) at every pixel centre; NaN where nothing is hit.
cv::Mat renderDepth(const LineScene& scene, const CameraModel& camera, int width, int height);

// Kinect/Xtion-like depth: Gaussian noise sigma = k z^2, then 16UC1 millimetres (0 = no depth) when as_millimetres,
// else 32FC1 metres (NaN = no depth).
cv::Mat makeSensorDepth(const cv::Mat& depth_m, double k_per_m, bool as_millimetres, std::mt19937& rng);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SYNTHETIC_LINE_SCENE_H
