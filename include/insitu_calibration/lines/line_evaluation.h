// Accuracy of extracted lines against true 3D edges: the measures of the line-extraction tests and of bench_lines,
// meant for the simulator-based checks as well.
#ifndef INSITU_CALIBRATION_LINES_LINE_EVALUATION_H
#define INSITU_CALIBRATION_LINES_LINE_EVALUATION_H

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/geometry/segment.h"

namespace insitu_calibration
{
// The image of the part of a true 3D segment in front of the camera, as its undistorted straight line.
struct TrueEdgeImage
{
  int edge = -1;                                // index into the 3D segments
  Eigen::Vector2d a = Eigen::Vector2d::Zero();  // undistorted px
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
};

// True segments that lie on one 3D line (every end point within max_distance_m of the other's line, directions within
// max_angle_deg), gaps between them allowed, joined into one segment spanning them all: a row of chairs' seat edges,
// a window's panes. An image line along such a row is the image of one straight 3D line, as the calibration uses it.
std::vector<Segment3d> mergeCollinearSegments(const std::vector<Segment3d>& segments, double max_distance_m = 0.001,
                                              double max_angle_deg = 0.05);

// Segments clipped to z >= near_m in the camera frame; segments fully behind are left out.
std::vector<TrueEdgeImage> projectEdges(const CameraModel& camera, const std::vector<Segment3d>& segments,
                                        double near_m = 0.05);

// Distance (px, distorted image) from a distorted pixel to the curved image of a true edge: the pixel is
// undistorted, its foot on the straight undistorted edge is distorted back, and the distance taken (exact to
// second order in the distance). nullopt when the foot falls beyond the edge's ends (by more than margin_px) or the
// model cannot (un)distort.
std::optional<double> distanceToEdge(const DivisionModel& distortion, const TrueEdgeImage& edge,
                                     const Eigen::Vector2d& pixel, double margin_px = 0.0);

struct ImageLineError
{
  int edge = -1;        // matched true edge (index into the 3D segments), -1 if none
  double rms_px = 0.0;  // over the samples of the polyline
  double max_px = 0.0;
  int samples = 0;
};

// Samples the polyline every step_px and matches it to the true edge with the smallest RMS distance among those
// that cover at least min_coverage of the samples, all within max_distance_px.
ImageLineError measureImageLine(const std::vector<Eigen::Vector2d>& polyline, const DivisionModel& distortion,
                                const std::vector<TrueEdgeImage>& edges, double max_distance_px = 2.0,
                                double step_px = 1.0, double min_coverage = 0.9);

struct Line3dError
{
  int edge = -1;            // matched true edge, -1 if none within the limits
  double angle_deg = 0.0;   // between the directions
  double distance_m = 0.0;  // RMS of the distances of the estimate's end points to the true (infinite) line
};

// Matches an estimated 3D segment to the true edge with the smallest end-point distance among those within
// max_angle_deg and max_distance_m, and whose extent overlaps the estimate's.
Line3dError measureLine3d(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const std::vector<Segment3d>& truth,
                          double max_distance_m = 0.1, double max_angle_deg = 5.0);

// Where a 3D line measured from a sensor position (an RGB-D line) lies off a true edge, in the sensor's terms: at the
// line's midpoint, its depth error along the ray from the sensor (positive: beyond the edge, where the ray passes
// closest to it) and its lateral offset normal to the interpretation plane (the plane through the sensor and the
// line, which the RGB edge fixes). Edge: as measureLine3d; -1 when none is within the limits.
struct ViewOffset
{
  int edge = -1;
  double depth_m = 0.0;         // signed, along the ray
  double lateral_m = 0.0;       // signed, normal to the interpretation plane
  double range_m = 0.0;         // of the midpoint from the sensor
  double ray_angle_deg = 90.0;  // between the ray and the line (small: the line runs away from the sensor)
};
ViewOffset measureViewOffset(const Eigen::Vector3d& sensor, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                             const std::vector<Segment3d>& truth, double max_distance_m = 0.05,
                             double max_angle_deg = 5.0);

// How much of a fixed camera's view the line map explains (issue 11's map coverage): of the image lines' length
// (distorted px), the share on a true edge (measureImageLine: 3 px, 60 % of the samples, under the true camera) for
// which the map holds a line: both end points within max_distance_m of the edge's line, overlapping the part of it
// the image line shows (a map line elsewhere on a long edge, a row of floor tiles, is out of the view).
// Collinear true edges count as one edge (mergeCollinearSegments), as they do for the calibration.
struct CoverageLine
{
  double length_px = 0.0;
  int edge = -1;         // index into mergeCollinearSegments(true_edges), -1: on no true edge
  Segment3d shown;       // the part of that edge the image line shows
  bool covered = false;  // the map holds it
};
struct MapCoverage
{
  std::vector<CoverageLine> details;  // per image line, in their order
  double total_px = 0.0;              // the image lines' length
  double on_edge_px = 0.0;            // of it, on a true edge
  double covered_px = 0.0;            // of it, on a true edge the map holds
  size_t lines = 0;
  size_t covered_lines = 0;
  double fraction() const { return total_px > 0.0 ? covered_px / total_px : 0.0; }
};
MapCoverage measureMapCoverage(const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                               const CameraModel& true_camera, const std::vector<Segment3d>& true_edges,
                               const std::vector<Segment3d>& map_lines, double max_distance_m = 0.01);

// Whether a 3D segment lies on a true edge's (infinite) line within max_distance_m (both end points) and overlaps
// the part [lo, hi] of it (arc length from edge.a towards edge.b): the test of measureMapCoverage.
bool segmentHoldsEdge(const Segment3d& edge, double lo, double hi, const Segment3d& line, double max_distance_m);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_LINE_EVALUATION_H
