// How the survey's Xtion saw given 3D segments (true edges a fixed camera shows): in how many keyframes a segment was
// in the RGB image and not hidden, and in how many the depth sensor returned depth along it. The diagnosis of map
// coverage (issue 11): an edge the map lacks was never in view, in view without depth (range, grazing angle), or in
// view with depth and lost by the line extraction or the map's thresholds.
#ifndef INSITU_CALIBRATION_SIMULATION_EDGE_SIGHTINGS_H
#define INSITU_CALIBRATION_SIMULATION_EDGE_SIGHTINGS_H

#include <limits>
#include <vector>

#include <Eigen/Geometry>

#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
namespace simulation
{
struct EdgeSightings
{
  int in_view = 0;     // keyframes with at least min_fraction of the segment in the image and not hidden
  int with_depth = 0;  // ... of those, with a depth return on at least min_fraction of it
  // The nearest range (m, optical z) of its samples in the keyframes where it was in view (infinity: never).
  double nearest_range_m = std::numeric_limits<double>::infinity();
};

struct SightingOptions
{
  double min_fraction = 0.5;  // of the segment's samples
  double sample_step_m = 0.02;
  double min_image_length_px = 25.0;  // the RGB segment detector's minimum length (RgbdLineOptions)
};

// The sightings of each segment from the Xtion RGB optical frames at rgb_poses (map frame): the world rendered at
// each pose (visibility only) and its noise-free depth under world.xtion.depth's no-return rules.
std::vector<EdgeSightings> sightSegments(const World& world, const std::vector<Segment3d>& segments,
                                         const std::vector<Eigen::Isometry3d>& rgb_poses,
                                         const SightingOptions& options = {});

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_EDGE_SIGHTINGS_H
