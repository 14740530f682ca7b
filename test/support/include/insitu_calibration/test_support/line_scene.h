// Scenes of flat-shaded planar quads with known straight 3D edges: the ground truth of the line-extraction tests and
// of bench_lines. They are drawn by the survey simulator's renderer (simulation/renderer.h: exact visibility, box-
// filtered n x n samples on every boundary pixel, any CameraModel with division-model distortion), so the tests and
// the simulator share one renderer. Depth is the optical-frame z of the surface under each pixel centre, optionally
// with the Kinect/Xtion noise model sigma_z = k z^2 (Khoshelham & Elberink 2012: k = 1.425e-3 / m) and millimetre
// quantisation.
#ifndef INSITU_CALIBRATION_TEST_SUPPORT_LINE_SCENE_H
#define INSITU_CALIBRATION_TEST_SUPPORT_LINE_SCENE_H

#include <random>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

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
  // The four edges of every quad (duplicates where quads share an edge).
  std::vector<Segment3d> edges() const;
};

// A 6 x 5 x 2.7 m room (z up, floor at z = 0) with doors, posters and boxes on the floor: edges of contrast at
// many directions, and depth discontinuities at the boxes. Greys vary with the seed.
LineScene makeRoomScene(std::mt19937& rng);

struct LineSceneRenderOptions
{
  int supersampling = 8;       // n x n samples per boundary pixel (1: no anti-aliasing)
  double noise_sigma = 2.0;    // grey levels, Gaussian, added to every pixel
  double blur_sigma_px = 0.0;  // optical blur (Gaussian) before the noise
};

// 8UC1 grey image through the camera (pose = world to camera), rendered by the survey simulator's renderer; pixels
// whose ray misses every quad are black.
cv::Mat renderGrey(const LineScene& scene, const CameraModel& camera, int width, int height,
                   const LineSceneRenderOptions& options, std::mt19937& rng);

// 32FC1 depth in metres (optical-frame z) at every pixel centre; NaN where nothing is hit.
cv::Mat renderDepth(const LineScene& scene, const CameraModel& camera, int width, int height);

// Kinect/Xtion-like depth: Gaussian noise sigma = k z^2, then 16UC1 millimetres (0 = no depth) when as_millimetres,
// else 32FC1 metres (NaN = no depth).
cv::Mat makeSensorDepth(const cv::Mat& depth_m, double k_per_m, bool as_millimetres, std::mt19937& rng);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_TEST_SUPPORT_LINE_SCENE_H
