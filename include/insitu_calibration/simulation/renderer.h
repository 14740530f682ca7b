// Software renderer of a World: z-buffered visibility, procedural textures, flat lighting, and anti-aliased edges.
//
//  1. Visibility at every pixel centre. Pin-hole views (lambda = 0) rasterise each polygon row by row: near-plane
//     clipping, even-odd spans, and 1/z interpolated exactly from the polygon's plane (1/z is affine in pixels).
//     Distorted views cast the exact ray of every pixel (undistort with the division model, then K^-1) against the
//     polygons whose distorted image bounds cover the pixel's 16x16 tile.
//  2. Shading: the texture at the visible point, times the surface's constant lighting factor.
//  3. Anti-aliasing: pixels where the surface or texture region changes between 4-neighbours are re-rendered with
//     n x n exact sub-pixel rays against the surfaces seen in their 3x3 neighbourhood, and averaged (box filter).
//     Features thinner than a pixel that cover no pixel centre nearby are missed.
// Pixel (0,0) is the centre of the top-left pixel; the optical frame is REP 103's (z forward, x right, y down).
#ifndef INSITU_CALIBRATION_SIMULATION_RENDERER_H
#define INSITU_CALIBRATION_SIMULATION_RENDERER_H

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace simulation
{
struct ViewCamera
{
  int width = 0;
  int height = 0;
  Intrinsics intrinsics;
  DivisionModel distortion;                                             // lambda = 0: pin-hole
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // the optical frame in the world

  static ViewCamera fromModel(const CameraModel& model, int width, int height);
  // Direction of the ray through a distorted pixel in the optical frame, scaled to z = 1 (nullopt where the
  // division model has no inverse).
  std::optional<Eigen::Vector3d> ray(double x, double y) const;
};

struct RenderOptions
{
  int supersampling = 3;  // n x n samples per edge pixel (1: no anti-aliasing)
  double near_m = 0.02;   // nothing closer is drawn
  bool ray_cast = false;  // use the ray caster also for pin-hole views (tests compare the two)
  bool color = true;      // false: visibility only (depth and surface)
};

struct RenderedView
{
  cv::Mat rgb;      // CV_8UC3, RGB order
  cv::Mat depth;    // CV_32FC1: z of the visible point in the optical frame, metres; 0 where nothing
  cv::Mat surface;  // CV_32SC1: index into World::surfaces, -1 where nothing
  cv::Mat region;   // CV_32SC1: surface * 1024 + texture region, -1 where nothing (a change is an edge)
  size_t antialiased_pixels = 0;
};

class Renderer
{
public:
  explicit Renderer(const World& world);  // keeps a reference to world

  RenderedView render(const ViewCamera& camera, const RenderOptions& options = {}) const;

  const World& world() const { return world_; }
  // The constant lighting factor of a surface.
  float shade(size_t surface) const { return shade_[surface]; }

private:
  struct Prepared;
  Prepared prepare(const ViewCamera& camera) const;
  void toCamera(const Prepared& p, const std::vector<Eigen::Vector3d>& ring, std::vector<Eigen::Vector3d>* out) const;
  // The nearest of the candidate surfaces that the ray (optical frame, z = 1) meets, at least near_m away, and its
  // depth; -1 when none.
  int nearestSurface(const Prepared& p, const int* candidates, size_t count, const Eigen::Vector3d& ray, double near_m,
                     double* depth) const;
  void renderVisibility(const ViewCamera& camera, const Prepared& p, const RenderOptions& options,
                        RenderedView* view) const;
  // Per image tile of 16 x 16 pixels, the surfaces whose distorted image may reach it.
  std::vector<std::vector<int>> surfacesPerTile(const ViewCamera& camera, const Prepared& p,
                                                const RenderOptions& options) const;
  Color shadeAt(const Prepared& p, int id, const Eigen::Vector3d& point, int* region) const;
  void shadePixels(const ViewCamera& camera, const Prepared& p, RenderedView* view) const;
  void antialias(const ViewCamera& camera, const Prepared& p, const RenderOptions& options, int samples,
                 RenderedView* view) const;
  void rasterize(const ViewCamera& camera, const Prepared& p, const RenderOptions& options, cv::Mat& inverse_depth,
                 cv::Mat& surface) const;
  void rayCast(const ViewCamera& camera, const Prepared& p, const RenderOptions& options, cv::Mat& depth,
               cv::Mat& surface) const;

  const World& world_;
  std::vector<float> shade_;
  std::vector<Eigen::Vector4d> uv_bounds_;  // per surface: min u, min v, max u, max v
};

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_RENDERER_H
