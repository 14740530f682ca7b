// What to survey next when a camera is refused: which parts of its view hold image lines that no map line explains,
// and where on the floor the robot should drive and look so that its Xtion maps them.
//
// The view is cut into a coarse grid of cells. Each image line is sampled every few pixels; a sample is explained
// when a map line, projected through the best camera available (the refused result's, else the prior's), passes
// within the tolerance. A cell is
//   unmapped  it holds image-line samples and most of them are unexplained (structure the map lacks),
//   empty     it holds neither image lines nor projected map lines,
//   covered   otherwise.
// Neighbouring unmapped cells form a region. The floor a region looks at: each of its cells' rays (a 3 x 3 grid of
// pixels per cell) meets the floor plane z = 0; a ray that does not meet it within max_range_m (or leaves the
// map's extent first: the bounding box of every map line, widened by map_margin_m) stops there, at floor height.
// The region's floor polygon is the convex hull of these points: the surfaces the region shows stand on it or at
// its far edge. The robot is sent to stand robot_standoff_m before the polygon's centroid (on the line from the
// camera's foot, or at the foot when the centroid is nearer), moved inside the map lines' extent by
// robot_clearance_m, looking towards the centroid, so that the Xtion (depth up to about 5 m) sees those surfaces
// within 1 to 4 m.
#ifndef INSITU_CALIBRATION_SURVEY_SURVEY_GUIDANCE_H
#define INSITU_CALIBRATION_SURVEY_SURVEY_GUIDANCE_H

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/lines/image_lines.h"

namespace insitu_calibration
{
class FixedCamera;

struct SurveyGuidanceOptions
{
  int columns = 8;
  int rows = 6;
  // A sample within this distance of a projected map line is explained: for a camera from a (refused) result, and,
  // as a share of the image width, for the prior's camera (which may be 10 degrees off).
  double tolerance_px = 12.0;
  double prior_tolerance_width_fraction = 0.08;
  double sample_step_px = 3.0;
  // A cell needs this many samples (of line length in px / sample_step_px) to count as holding image lines, and
  // this share of them unexplained to be unmapped.
  int min_samples = 8;
  double min_unexplained_share = 0.6;
  double max_range_m = 10.0;
  double map_margin_m = 0.5;
  double robot_standoff_m = 2.0;
  double robot_clearance_m = 0.4;  // the robot stands at least this far inside the map lines' extent
  size_t max_regions = 6;          // the largest regions (by unexplained image lines) are kept
};

enum class GuidanceCell
{
  kCovered,
  kUnmapped,
  kEmpty
};

struct UnmappedRegion
{
  std::vector<int> cells;                      // row * columns + column
  std::string where;                           // "left", "top right", "centre", ... of the view
  size_t image_lines = 0;                      // image lines mostly unexplained whose samples are mostly here
  std::vector<Eigen::Vector2d> floor_polygon;  // map frame, z = 0, counter-clockwise
  Eigen::Vector2d robot_position = Eigen::Vector2d::Zero();   // map frame
  Eigen::Vector2d look_direction = Eigen::Vector2d::UnitX();  // unit, map frame
};

struct SurveyGuidance
{
  int width = 0;
  int height = 0;
  int columns = 0;
  int rows = 0;
  std::vector<GuidanceCell> cells;        // row-major
  std::vector<UnmappedRegion> regions;    // largest first
  cv::Rect cellRect(int cell) const;      // the pixels of a cell
  size_t count(GuidanceCell kind) const;  // cells of a kind
  // "survey the left part of the view (or: the whole view): 12 image lines there have no map line; drive the robot to
  // about (2.1, 3.4) in the map and look towards (0.71, -0.71)", one clause per region joined by "; also ", or empty
  // without regions.
  std::string sentence() const;
};

// The guidance from the image lines (distorted px), the map lines and a camera (distortion included).
// tolerance_px: see SurveyGuidanceOptions.
SurveyGuidance computeSurveyGuidance(const CameraModel& camera, int width, int height,
                                     const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                     const std::vector<Segment3d>& map_lines, double tolerance_px,
                                     const SurveyGuidanceOptions& options = {});

// The guidance for a fixed camera after a refusal: its median image's lines (extracted with the camera's
// distortion) against the map, through the refused result's camera if the refusal came that far, else the camera's
// current one (its calibration or its prior, with the prior's wider tolerance). Errors: no camera (neither prior
// nor calibration), no image, the extraction failed.
Expected<SurveyGuidance> guideSurvey(const FixedCamera& camera, const std::vector<Segment3d>& map_lines,
                                     const ImageLineOptions& image_line_options,
                                     const SurveyGuidanceOptions& options = {});

// The region's floor polygon as triangles (a fan: the polygon is convex) at a height, for a triangle-list marker.
std::vector<Eigen::Vector3d> floorTriangles(const UnmappedRegion& region, double height_m = 0.02);

// The refusal's text with the guidance's sentence appended ("<error>. What to do: <sentence>"), or the error alone;
// for a view too weakly determined (kDegenerate) that is mapped already where it has image lines (at most an eighth
// of those cells unmapped), also what helps instead of more of the same survey.
std::string describeRefusal(const Error& error, const SurveyGuidance& guidance);

// The image (grey or colour; black canvas when empty) with the unmapped cells shaded orange and numbered by
// region, the empty cells darkened, and a legend.
cv::Mat drawSurveyHint(const cv::Mat& image, const SurveyGuidance& guidance);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_SURVEY_GUIDANCE_H
