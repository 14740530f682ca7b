// The surfaces the survey's depth measured, as a sparse set of occupied voxels, to tell which map lines a fixed
// camera cannot see: a line in a room behind a wall, or behind a cupboard, projects into the camera's image where no
// edge of it can appear, and the final check (image_explanation.h) would count it against a correct camera (a
// corridor's camera sees the map lines of the rooms on both sides through their walls).
//
// Each keyframe's depth is sampled every pixel_step pixels; a measured point and the points up to 1.5 voxels farther
// along its ray are marked, so that a sight line crossing a surface at any angle meets two voxels of it. A sight line
// counts as blocked when it meets at least min_hits occupied voxels between near_margin_m from the camera and a margin
// before its target that grows with the range (target_margin_m + target_margin_per_m * range): the target's own
// surface, which a sight line at a grazing angle runs along, must not hide it. Within that margin a surface that does
// not lead to the target's line still hides it (the near faces of a column hide its far edge; options below).
// Surfaces the depth never measured hide nothing (the test can only keep a hidden line, never drop a visible one by
// lack of data).
//
// Memory grows with the measured surface area (about 0.8 MB per 100 m^2 at 5 cm voxels), never with the images.
#ifndef INSITU_CALIBRATION_MAP_SURFACE_VOXELS_H
#define INSITU_CALIBRATION_MAP_SURFACE_VOXELS_H

#include <cstdint>
#include <unordered_set>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/lines/rgbd_frame.h"

namespace insitu_calibration
{
struct SurfaceVoxelOptions
{
  bool enabled = true;
  double voxel_m = 0.05;
  int pixel_step = 4;                 // depth pixels sampled in each direction
  double max_range_m = 6.0;           // farther depth is not inserted (noise grows as z^2)
  double near_margin_m = 0.3;         // sight lines start this far from the camera (its own wall or ceiling)
  double target_margin_m = 0.3;       // ... and end this far before the target,
  double target_margin_per_m = 0.08;  // plus this times the range
  int min_hits = 2;
  // For a point of a map line, inside that margin down to other_surface_margin_m before it, a sight line still
  // counts as blocked where it meets a surface that is not the line's own: one from which the way to the line across
  // its direction leaves the measured surfaces for 0.1 m or more (the near face of a column, a box or a chair, with the
  // object's empty inside between it and a far edge). The floor or wall a sight line grazes near its line leads to the
  // line without a gap and does not count. 0: off (the margin above only).
  double other_surface_margin_m = 0.1;
  double sample_step_m = 0.1;  // along a map line, where its visibility is tested (at most 100 samples per line)
  // With follow_adjustment a keyframe keeps its depth samples thinned to one per cell of this size (camera frame), so
  // that its surfaces can be inserted again under the map adjustment's corrected pose (Survey; 12 bytes a sample, at
  // most 19200 samples, 0.23 MB, per keyframe of a 640x480 depth image at pixel_step 4; fewer where the surfaces are
  // near).
  double kept_cell_m = 0.025;
  // Whether the surfaces follow the map adjustment (keyframes keep their samples, kept_cell_m); off by default: on
  // the default world it rescued one of the four cameras refused at 2 cm / 0.5 deg (seed 2, tuned on), none of the
  // three held out (docs/measurements.md, occluders under the adjusted poses).
  bool follow_adjustment = false;
};

class SurfaceVoxels
{
public:
  explicit SurfaceVoxels(const SurfaceVoxelOptions& options = {});

  // The frame's valid depth (in range) under its pose, T_map_camera.
  void insertDepth(const RgbdFrame& frame);
  // The frame's depth samples (every pixel_step pixels, within max_range_m) in its camera frame; with cell_m > 0 only
  // the first sample in each cell of that size (a keyframe's compact copy).
  std::vector<Eigen::Vector3f> depthSamples(const RgbdFrame& frame, double cell_m = 0.0) const;
  // Depth samples (camera frame, from depthSamples) under the camera pose T_map_camera, each with the layer behind.
  void insertSamples(const Eigen::Isometry3d& T_map_camera, const std::vector<Eigen::Vector3f>& samples);
  void insert(const Eigen::Vector3d& point);
  bool occupied(const Eigen::Vector3d& point) const;
  size_t size() const { return voxels_.size(); }
  const SurfaceVoxelOptions& options() const { return options_; }

  // Whether measured surfaces lie between a camera at `from` and the point `to` (the margins above); with the
  // direction of the map line `to` lies on (any length), surfaces other than the line's own within the target's
  // margin count too (other_surface_margin_m).
  bool blocks(const Eigen::Vector3d& from, const Eigen::Vector3d& to) const;
  bool blocks(const Eigen::Vector3d& from, const Eigen::Vector3d& to, const Eigen::Vector3d& line_direction) const;

  // The parts of each segment that a camera at `center` sees past the measured surfaces (a segment may split;
  // hidden parts are dropped).
  std::vector<Segment3d> unoccludedParts(const Eigen::Vector3d& center, const std::vector<Segment3d>& lines) const;

  // Whether no point of the segment (sampled every 2.5 sample_step_m) can be seen from any of the viewpoints: a
  // line no camera near a prior could see.
  bool hiddenFromAll(const std::vector<Eigen::Vector3d>& viewpoints, const Segment3d& line) const;

private:
  uint64_t key(const Eigen::Vector3d& point) const;
  // Whether the measured surface at `point` leads to the line through `target` along `direction` (unit): no two
  // empty voxels in a row on the way across the line's direction.
  bool onSurfaceThrough(const Eigen::Vector3d& point, const Eigen::Vector3d& target,
                        const Eigen::Vector3d& direction) const;

  SurfaceVoxelOptions options_;
  std::unordered_set<uint64_t> voxels_;
};

// The nearest and the farthest depth a frame measured in each cell of a coarse grid over its image (undistorted
// normalised coordinates, square cells): in front of the nearest, that part of the view is free; beyond the
// farthest, it is hidden. Triangulated lines at points a keyframe saw through, or hidden from the keyframes that
// saw them, are ghosts (map/triangulated_lines.h). A few hundred floats per keyframe, no image.
struct DepthRangeGrid
{
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // the first cell's corner
  double cell = 0.0;
  int cols = 0;
  int rows = 0;
  std::vector<float> nearest_m;   // row-major; 0: no depth in the cell
  std::vector<float> farthest_m;  // row-major; 0: a pixel of the cell without depth (it may look past the rest)

  // The nearest and the farthest depth in the cell holding the point (normalised coordinates); 0 outside the grid
  // or without depth.
  double nearestAt(const Eigen::Vector2d& normalised) const;
  double farthestAt(const Eigen::Vector2d& normalised) const;
  // The cell's index (row-major), or -1 outside the grid.
  long cellOf(const Eigen::Vector2d& normalised) const;
};

// The frame's grid of cells cell_px wide (at the image's centre), from every pixel_step-th depth pixel.
DepthRangeGrid depthRangeGrid(const RgbdFrame& frame, double cell_px, int pixel_step);
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MAP_SURFACE_VOXELS_H
