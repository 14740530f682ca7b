// Direction lines (CorrespondenceSet::direction_lines): the unmatched image lines of a camera that are images of edges
// of known directions (the map's vertical, the building's main horizontal directions), found under a camera that the
// matched lines fixed. They join the final calibration (line_matcher.cpp, calibrateFinally).
#ifndef INSITU_CALIBRATION_MATCHING_DIRECTION_LINES_H
#define INSITU_CALIBRATION_MATCHING_DIRECTION_LINES_H

#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/solvers/correspondences.h"

namespace insitu_calibration
{
// The directions of edges the final calibration may know unmatched image lines by (DirectionLine without image): the
// map's vertical (z, REP 103, exact) and, with `with_horizontal`, the building's main horizontal directions: those
// along which at least min_support matched map lines run (within 2 deg of each other, 3 deg of level), their
// length-weighted mean, the two most supported; two within 2 deg of square share one azimuth, and their azimuth is
// estimated with the camera (DirectionLine::azimuth_group).
std::vector<DirectionLine> knownDirectionsOf(const std::vector<Segment3d>& matched_map_lines, bool with_horizontal,
                                             size_t min_support);

// The image lines left unmatched that are images of edges of one of `directions` under `camera` (direction lines): a
// chord of at least min_length_px, every point within max_px (undistorted) of the line through that direction's
// vanishing point and the polyline's middle, and of no other direction (a line the horizon holds passes through
// every horizontal vanishing point: it says nothing of one). Marks them in *taken (sized to image_lines). None when
// min_length_px is 0.
std::vector<DirectionLine> directionLinesOf(const std::vector<LineMatch>& matches,
                                            const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                            const CameraModel& camera, const std::vector<DirectionLine>& directions,
                                            double min_length_px, double max_px, std::vector<bool>* taken);
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MATCHING_DIRECTION_LINES_H
