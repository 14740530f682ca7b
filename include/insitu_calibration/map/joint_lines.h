// Map lines that are one flank of a joint a fixed camera does not resolve. The Xtion, 1-2 m from a wall or floor,
// maps both edges of a mortar, grout or plank joint (2-12 mm wide in the generated buildings) as two parallel map
// lines. A fixed camera several metres away sees such a joint as a blurred ridge under a pixel or two wide: the
// edge it fits lies somewhere about the joint, not on either flank the map holds. On building 306471 (office,
// cam_a, 1920x1080 at 9-11 m from a brick wall) the image lines matched to 1 cm mortar joints were 0.15-0.74 px off
// their true edge while isolated edges were within 0.05 px: a few such lines pulled the camera 40 mm off even with
// every match right. Each such map line's sigma is grown by half the joint's width, so the fit weighs it as what
// it is (an edge known to within the joint) and the reported uncertainty includes it.
#ifndef INSITU_CALIBRATION_MAP_JOINT_LINES_H
#define INSITU_CALIBRATION_MAP_JOINT_LINES_H

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/geometry/segment.h"

namespace insitu_calibration
{
struct UnresolvedJointOptions
{
  bool enabled = true;
  double max_angle_deg = 2.0;      // twins are parallel within this
  double max_separation_m = 0.03;  // and this close (a joint; wider gaps are separate edges)
  double min_overlap = 0.3;        // of the shorter line's length, along the lines
  double min_resolved_px = 2.0;    // twins that project closer than this (across the line) are one ridge
};

// Map lines of a wall's or floor's texture: joints of bricks, tiles, planks or panelling, recognised in the map by
// their repetition (a structural edge, such as a corner, a door frame or a shelf's front, stands nearly alone).
struct TextureLineOptions
{
  size_t min_neighbours = 4;   // distinct parallel lines beside a line, half of them on either side, make it
                               // texture (a line at a texture's border is not); 0: none is
  double max_spacing_m = 0.3;  // beside it: within this across it,
  double max_angle_deg = 3.0;  // parallel within this,
  double min_overlap = 0.3;    // overlapping it along by this share of the shorter line
  double distinct_m = 0.005;   // offsets closer than this are one line (an edge mapped twice)
};

// When b runs beside a (parallel within cos_max, overlapping along a by at least min_overlap of the shorter length):
// the separation from a to b in the middle of their overlap, across a.
std::optional<Eigen::Vector3d> besideSeparation(const Segment3d& a, const Segment3d& b, double cos_max,
                                                double min_overlap);

// Per line, whether it is texture: at least min_neighbours lines run beside it at distinct offsets, at least half of
// them on either side of it.
std::vector<bool> textureLines(const std::vector<Segment3d>& lines, const TextureLineOptions& options = {});

// Per map line, its sigma (m) grown in quadrature by half the separation from its farthest unresolved twin: a
// parallel map line within max_separation_m that overlaps it and that, seen from `viewpoint` through a focal length
// of `focal_px`, lies closer than min_resolved_px across it in the image (a cluster of such lines blurs into one
// ridge whose fitted edge may lie anywhere across it). Lines without one keep their sigma. Empty sigmas_m count as 0
// for every line; otherwise they must have one entry per line (else they are returned unchanged, as when off).
std::vector<double> unresolvedJointSigmas(const std::vector<Segment3d>& lines, const std::vector<double>& sigmas_m,
                                          const Eigen::Vector3d& viewpoint, double focal_px,
                                          const UnresolvedJointOptions& options = {});
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MAP_JOINT_LINES_H
