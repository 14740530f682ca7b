// Image lines and projected map lines side by side: the geometry every step of the matcher compares.
#ifndef INSITU_CALIBRATION_MATCHING_LINE_PROJECTION_H
#define INSITU_CALIBRATION_MATCHING_LINE_PROJECTION_H

#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/geometry/segment.h"

namespace insitu_calibration
{
namespace matching
{
constexpr double kDegToRad = M_PI / 180.0;

// An image line summarised for matching: its points, chord direction and length.
struct ImageChord
{
  const std::vector<Eigen::Vector2d>* points;
  Eigen::Vector2d first;
  Eigen::Vector2d last;
  Eigen::Vector2d mid;
  Eigen::Vector2d direction;
  double length;
};

// A 3D line as the current camera sees it: the visible interval and its distorted projection.
struct ProjectedLine
{
  bool visible = false;
  double t0 = 0.0;
  double t1 = 1.0;
  std::vector<Eigen::Vector2d> polyline;
  Eigen::Vector2d first;
  Eigen::Vector2d last;
  Eigen::Vector2d direction;
  double length = 0.0;
};

bool insideImage(const Eigen::Vector2d& m, int width, int height);
std::vector<ImageChord> summarizeImageLines(const std::vector<std::vector<Eigen::Vector2d>>& image_lines);
// The visible part of a 3D line projected at `samples` points.
ProjectedLine projectLine(const CameraModel& camera, const Segment3d& segment, int width, int height, int samples);
// Angle between undirected directions, degrees.
double angleBetween(const Eigen::Vector2d& a, const Eigen::Vector2d& b);
// Fraction of the image line's chord covered by the projected line's chord (projected onto the image line).
double overlap(const ImageChord& image, const ProjectedLine& projected);
// Mean distance of the image line's points to the projected polyline.
double meanDistance(const ImageChord& image, const ProjectedLine& projected);
// Fast distance for the search: the image chord's end points and midpoint to the projected chord's line.
double chordDistance(const ImageChord& image, const ProjectedLine& projected);
}  // namespace matching
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MATCHING_LINE_PROJECTION_H
