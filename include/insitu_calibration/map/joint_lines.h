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
