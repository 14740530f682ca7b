// Map lines on a ceiling: a horizontal plane above the Xtion that its depth measured, extended by ray-plane
// intersection to the lines on it whose own depth is too poor for the map (issue 11). The Xtion looks up at the
// ceiling at a slant: a line's own depth along it gives its position only to several millimetres (its observations
// exceed LineMapOptions::max_sigma_m and are not inserted), or none at all, while the plane's height is measured by
// many lines on it. A 2D segment of a keyframe above the horizon, without a depth line or with one too uncertain for
// the map but on the plane, is placed on the plane like a floor line (floor_lines.h: predicted error from the pixel
// noise, the mount's tilt and the plane's height error; confirmed from several keyframes by the slope test, which
// tells an edge below the plane, a wall's or a window's, from one on it; left out where a depth map line holds it).
#ifndef INSITU_CALIBRATION_MAP_CEILING_LINES_H
#define INSITU_CALIBRATION_MAP_CEILING_LINES_H

#include <optional>
#include <vector>

#include "insitu_calibration/lines/line_map.h"
#include "insitu_calibration/map/floor_lines.h"
#include "insitu_calibration/map/line_map_adjustment.h"

namespace insitu_calibration
{
struct CeilingLineOptions
{
  bool enabled = false;
  // The plane: the height (map z) shared by the most horizontal depth lines (within max_tilt_deg of level) at least
  // min_clearance_m above the camera, within plane_tolerance_m of each other, at least min_plane_lines of them; its
  // height the median of those.
  double min_clearance_m = 0.5;
  // ... and at least min_height_m above the floor (the caller's floor_height_m: the survey passes its floor lines'
  // floor/height): a cabinet's or a shelf's top seen from below by a low-mounted Xtion is not a ceiling (a
  // generated office's 1.77 m cabinet top was taken for one and put 176 false lines into a camera's view). Fixed
  // cameras hang 2.4 m and higher, under the ceiling.
  double min_height_m = 2.2;
  double max_tilt_deg = 2.0;
  double plane_tolerance_m = 0.02;
  int min_plane_lines = 20;
  // A candidate whose depth line (or depth samples) lies farther from the plane than depth_tolerance_m +
  // depth_tolerance_per_m2 * range^2 is not on it.
  double depth_tolerance_m = 0.02;
  double depth_tolerance_per_m2 = 0.006;
  // Placement, error prediction and confirmation as for floor lines (floor_height_m is replaced by the plane's
  // height; height_sigma_m is the plane's height error beyond its measured standard error).
  FloorLineOptions lines = defaultLineOptions();

  static FloorLineOptions defaultLineOptions();
};

// The ceiling's height and its standard error, measured from the keyframes' depth lines (all of them, also those
// too uncertain for the map); nullopt when no plane above the camera and min_height_m has enough lines.
struct PlaneHeight
{
  double height_m = 0.0;
  double sigma_m = 0.0;
  int lines = 0;
};
std::optional<PlaneHeight> measureCeilingHeight(const std::vector<Keyframe>& keyframes,
                                                const CeilingLineOptions& options, double floor_height_m);

// The confirmed ceiling lines of the keyframes' ceiling observations (Keyframe::ceiling) under the corrected poses
// (corrections empty or one per keyframe) that no line of `depth_lines` holds, the floor at z = floor_height_m in
// the map. MapLine::source kCeiling, MapLine::sigma() their predicted error.
std::vector<MapLine> confirmCeilingLines(const std::vector<Keyframe>& keyframes,
                                         const std::vector<PoseCorrection>& corrections,
                                         const std::vector<MapLine>& depth_lines, const CeilingLineOptions& options,
                                         double floor_height_m);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MAP_CEILING_LINES_H
