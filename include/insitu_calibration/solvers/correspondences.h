// 3D-to-2D correspondences, the input of every solver.
#ifndef INSITU_CALIBRATION_SOLVERS_CORRESPONDENCES_H
#define INSITU_CALIBRATION_SOLVERS_CORRESPONDENCES_H

#include <string>
#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"

namespace insitu_calibration
{
// One straight 3D line and its image. The image is a polyline of distorted pixels in order along the line: each
// consecutive pair is a "part" (a straight line in the image only when there is no distortion), and every 3D point
// pairs with every part (the paper's "many 3D points to one 2D line"). The 3D points need not correspond to the
// image points.
struct LineCorrespondence
{
  std::vector<Eigen::Vector2d> image;  // >= 2 distorted pixels
  std::vector<Eigen::Vector3d> world;  // >= 1 points on the 3D line, world frame, metres
  // How far the 3D line may be off, m (one sigma, across it; 0: exact). A surveyed line's error moves all its image
  // residuals together; the refinement weights the line by it (RefinementOptions::weight_by_world_sigma).
  double world_sigma_m = 0.0;
  // How far each world point may be off, m (one sigma per axis; a surveyed point; 0: exact, as a BIM model's line;
  // negative: not given, the refinement's world_sigma_m or its estimate applies). Used by LineResidual::kJoint.
  double world_point_sigma_m = -1.0;

  size_t partCount() const { return image.size() < 2 ? 0 : image.size() - 1; }
  // Point-line pairs this line contributes: world points x parts.
  size_t constraintCount() const { return world.size() * partCount(); }
};

struct PointCorrespondence
{
  Eigen::Vector2d image;  // distorted pixel
  Eigen::Vector3d world;  // metres
};

// The image of an edge whose direction in the world is known but not its position (a vertical edge: the map's z axis,
// REP 103): it must pass through that direction's vanishing point. That constrains the rotation, the focal length and
// the principal point (never the position), and it separates a turned camera from a shifted principal point where
// the matched lines' view alone moves the image nearly alike for both (the vanishing point moves more than the view).
struct DirectionLine
{
  std::vector<Eigen::Vector2d> image;                    // >= 2 distorted pixels along the edge
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // world frame, unit
  // Lines of one group >= 0 share an unknown turn of their directions about the world's z axis, estimated with the
  // camera (a building's horizontal directions as the map's lines give them, a fraction of a degree off: their
  // error then enters the camera's uncertainty instead of biasing it). -1: the direction is exact (the vertical).
  int azimuth_group = -1;
};

struct CorrespondenceSet
{
  std::string camera_name;
  int image_width = 0;
  int image_height = 0;
  std::vector<LineCorrespondence> lines;
  std::vector<PointCorrespondence> points;
  // Image polylines of edges known to be straight in the world but without a 3D line (plumb lines): they constrain
  // only the distortion (and weakly the principal point), through the refinement; the DLT does not use them.
  std::vector<std::vector<Eigen::Vector2d>> straight_lines;
  // Image polylines of edges of a known direction (DirectionLine), through the refinement only, as plumb lines.
  std::vector<DirectionLine> direction_lines;

  Eigen::Vector2d imageCenter() const { return insitu_calibration::imageCenter(image_width, image_height); }
  size_t lineConstraintCount() const;
  // True when a line has 3 or more image points or point correspondences exist: the data that identify lambda.
  bool canIdentifyDistortion() const;
  // Rejects NaN/infinite values, lines with fewer than 2 image points or no world point, coincident image points of
  // a part, direction lines without a direction or with fewer than 2 image points, and non-positive image sizes.
  Status validate() const;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_CORRESPONDENCES_H
