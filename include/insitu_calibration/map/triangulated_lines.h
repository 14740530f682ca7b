// Map lines beyond the depth range triangulated from the Xtion's RGB images (issue 11): a 2D line of a keyframe's
// RGB image without a depth-based 3D line spans, under the keyframe's (corrected) pose, a plane through the camera
// centre. Two such planes of keyframes a baseline apart that meet at min_plane_angle_deg or more intersect in a
// candidate 3D line, in front of both cameras where both segments see it. The candidate becomes a map line only
// when the segments of at least min_keyframes keyframes in all (each within confirm_px of its projection, point to
// line at both end points, and overlapping it) support it: two views always agree on a line, a third one tests it.
// It is then refined by least squares over all its supporting segments (point-to-line, px); its predicted error is
// that small problem's covariance at the pixel noise, with the keyframe poses' errors propagated over its range.
// A line that a map line already holds (depth or floor) is left out, and so are ghosts of wrongly paired views: lines
// among repeated parallel edges, under the floor, where keyframes' depth saw free space, or hidden from the keyframes
// that saw them.
#ifndef INSITU_CALIBRATION_MAP_TRIANGULATED_LINES_H
#define INSITU_CALIBRATION_MAP_TRIANGULATED_LINES_H

#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/lines/line_map.h"
#include "insitu_calibration/map/line_map_adjustment.h"

namespace insitu_calibration
{
struct TriangulatedLineOptions
{
  bool enabled = false;
  double pixel_sigma_px = 0.3;       // the RGB segments' end points across the line
  double pose_sigma_m = 0.002;       // the keyframes' positions relative to each other (after the adjustment)
  double pose_sigma_deg = 0.02;      // ... and their orientations
  double min_plane_angle_deg = 2.0;  // the two interpretation planes of a candidate meet at least at this angle
  // Candidates from the pairs of keyframes these many keyframes apart (0.1 m or 5 deg between keyframes: baselines
  // of about 0.6, 1.2 and 2.4 m), tested first on the keyframes between them; the support is sought up to the
  // largest of them before and after the pair.
  std::vector<int> pair_spans = {6, 12, 24};
  double confirm_px = 1.0;     // a supporting segment's end points from the candidate's image
  double max_angle_deg = 2.0;  // of a supporting segment to the candidate's image
  int min_keyframes = 5;       // keyframes whose segments support the line (at least 3)
  // Every supporting camera sees the line at least this far in front (nearer, depth would have lifted it: an RGB
  // line there without depth is mostly a ghost of nearly coplanar views, floor lines along the route on the
  // hall world) ...
  double min_range_m = 4.0;
  double max_range_m = 25.0;  // ... and at most this far
  double min_length_m = 0.2;
  double max_sigma_m = 0.02;  // lines predicted to be worse are dropped
  // Nothing the robot sees lies under the floor it stands on (z = floor_height_m in the map; the survey passes its
  // floor's): a line with an end more than below_floor_m under it is a ghost of views paired wrongly.
  double floor_height_m = 0.0;
  double below_floor_m = 0.05;
  // Repeated parallel edges (brick courses, tiles, planks, stripes) let the keyframes pair different edges into a
  // line none of them is, which the repeated edges then confirm in other views too: on a generated hall, lines
  // 0.2-0.8 m in front of a brick wall 8 m away, predicted within 2 cm. A line whose image has two or more other
  // parallel segments beside it (overlapping, within repetition_px, farther than confirm_px) in at least half of its
  // supporting keyframes is left out; one neighbour alone (a frame's other edge) is not repetition. 0: off.
  double repetition_px = 10.0;
  // Free space: a keyframe's depth saw through a point (Keyframe::depth_grid: the point within free_max_range_m of
  // it, and the nearest depth in its part of the image farther by free_margin_m + free_margin_per_m2 * z^2) where
  // nothing stands; a line with a third or more of its points (every 0.1 m) seen through is left out. Lines beyond
  // the depth range are tested by the keyframes that came nearer. So is a line whose supporting keyframes' depth
  // hid a third or more of its points (all depth in that part of the image nearer than the point by the margin, at
  // the depth's range): a line behind a wall.
  double free_margin_m = 0.05;
  double free_margin_per_m2 = 0.01;
  double free_max_range_m = 4.5;
};

// The lines triangulated from the keyframes' RGB-only segments (Keyframe::rgb) under the corrected poses
// (corrections: empty or one per keyframe) that none of `map_lines` already holds. MapLine::source is kTriangulated,
// MapLine::sigma() the predicted error (larger axis, at the worse end point), MapLine::support the number of
// supporting segments.
std::vector<MapLine> triangulateLines(const std::vector<Keyframe>& keyframes,
                                      const std::vector<PoseCorrection>& corrections,
                                      const std::vector<MapLine>& map_lines, const TriangulatedLineOptions& options);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MAP_TRIANGULATED_LINES_H
