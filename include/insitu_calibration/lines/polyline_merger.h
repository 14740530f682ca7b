// Merging of collinear segment fragments into one polyline per straight 3D edge.
//
// Under the division model a straight 3D line images to a circular arc, so a detector returns it as several short
// fragments with slowly turning directions. The fragments are grouped in coordinates undistorted by the best
// available division model (lambda = 0 and the image centre before the first calibration: then the groups absorb
// the bend), greedily from the longest fragment: a fragment joins a group when its direction agrees with the
// group's curve (max_angle_deg), the gap along the curve is at most max_gap_px, and the group's curve refitted with
// it - a parabola in the group's principal frame, a close approximation of a flat circular arc - stays within
// max_offset_px of every sampled fragment point while bending by at most max_sagitta_ratio (sagitta over chord).
// The merged line is returned as a polyline of distorted pixels sampled on the fitted curve, with parts at most
// max_part_length_px long (so a long line has more than two points, as identifying lambda requires) and short enough
// that a part's chord deviates at most max_part_sagitta_px from the curve (far below the fine-tuning's precision).
#ifndef INSITU_CALIBRATION_LINES_POLYLINE_MERGER_H
#define INSITU_CALIBRATION_LINES_POLYLINE_MERGER_H

#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/lines/segment_detector.h"

namespace insitu_calibration
{
struct PolylineMergeOptions
{
  double max_offset_px = 1.5;         // every fragment point within this of the merged curve
  double max_angle_deg = 3.0;         // fragment direction against the curve's tangent
  double max_gap_px = 40.0;           // along the curve, between a fragment and the group
  double max_sagitta_ratio = 0.01;    // bend allowed for an unknown distortion: sagitta / chord of the group
  double max_part_length_px = 80.0;   // polyline vertices at most this far apart
  double max_part_sagitta_px = 0.02;  // and close enough that a part deviates this little from the fitted curve,
  double min_part_length_px = 20.0;   // but not closer than this (fine-tuning needs samples)
  double min_length_px = 30.0;        // shorter merged lines are dropped
  double sample_spacing_px = 8.0;     // fragments are represented by points this far apart (end points included)
};

struct ImagePolyline
{
  std::vector<Eigen::Vector2d> points;  // distorted px, in order along the line, >= 2
  std::vector<int> fragments;           // indices of the merged input segments
  double length_px = 0.0;               // chord length (undistorted coordinates)
  double rms_residual_px = 0.0;         // of the fragment points about the fitted curve
};

// Groups the segments (distorted px) into polylines, longest first. Segments the distortion model cannot undistort
// are ignored. Never fails: no segment gives no polyline.
std::vector<ImagePolyline> mergeSegments(const std::vector<Segment2d>& segments, const DivisionModel& distortion,
                                         const PolylineMergeOptions& options = PolylineMergeOptions());

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_POLYLINE_MERGER_H
