// A minimal solver for a camera's pose and focal length from four 2D-3D line correspondences, two of them on
// vertical 3D lines (the map's z axis is vertical). Principal point known, square pixels, no distortion. One solver,
// no robust layer (PoseLib's style): the matcher's hypothesis generation (src/core/matching/hypotheses.cpp) samples
// its inputs and scores what it returns.
//
// The method (docs/survey_calibration.md, "Hypotheses from line correspondences"): the two vertical lines' images meet
// at the vertical vanishing point v; for a focal length f the world's up axis in the camera is u(f) = normalize(K^-1 v)
// (the sign that makes it point to the top of the image), so the rotation is R = R_u(f) Rz(theta). Each of the two
// other lines constrains theta through its direction (n^T R d = 0, n = K^T l the normal of the line's back-projected
// plane): a cos(theta) + b sin(theta) + c = 0. Both together leave one equation in f (the solution (cos, sin) of the
// 2x2 linear system must have unit norm), solved by bracketing its sign changes over a range of fields of view and
// bisection. The translation is then linear: n_i^T (R X_i + t) = 0 for the four lines (least squares).
//
// Related work: absolute pose from 2D-3D line pairs with a known vertical direction (Horanyi & Kato, "Multiview
// absolute pose using 3D-2D perspective line correspondences and vertical direction", ICCV Workshops 2017) takes
// the vertical from an IMU with a calibrated camera, and the direct least-squares line-pair solver of Abdellali,
// Frohlich & Kato ("A direct least-squares solution to multi-view absolute and relative pose from 2D-3D perspective
// line pairs", ICCV Workshops 2019) needs a calibrated camera too; here the vertical comes from the image (its
// vanishing point) and depends on the unknown focal length, as in focal length from orthogonal vanishing points
// (Caprile & Torre, "Using vanishing points for camera calibration", IJCV 1990). Unknown-focal minimal solvers from
// points (Bujnak, Kukelova & Pajdla, "A general solution to the P4P problem for camera with unknown focal length", CVPR
// 2008) are closed-form; this one is a 1-D numerical root search.
#ifndef INSITU_CALIBRATION_SOLVERS_VERTICAL_LINES_FOCAL_POSE_H
#define INSITU_CALIBRATION_SOLVERS_VERTICAL_LINES_FOCAL_POSE_H

#include <array>
#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/geometry/segment.h"

namespace insitu_calibration
{
// One correspondence: two points of the image line (undistorted px) and two points of the 3D line (world, m).
struct ImageMapLine
{
  Eigen::Vector2d image_a = Eigen::Vector2d::Zero();
  Eigen::Vector2d image_b = Eigen::Vector2d::Zero();
  Segment3d world;
};

struct VerticalLinesSolverOptions
{
  double min_fov_deg = 10.0;  // horizontal field of view range searched for f
  double max_fov_deg = 150.0;
  int fov_samples = 240;                // brackets of the 1-D search (log-spaced in f)
  double vertical_tolerance_deg = 5.0;  // lines 0 and 1 must be within this of world z, lines 2 and 3 outside it
  double max_residual =
      1e-6;  // a solution is kept when every line's plane passes within this (relative) of its 3D line
};

// lines[0], lines[1]: on vertical 3D lines; lines[2], lines[3]: on non-vertical 3D lines whose directions differ.
// Returns every camera (pin-hole, fx = fy, principal point as given, no distortion) consistent with the four lines;
// none when the input is degenerate (vertical lines that are not vertical, image lines of the vertical pair parallel
// to each other at the same place, f not determined by the lines).
std::vector<CameraModel> solveVerticalLinesFocalPose(const std::array<ImageMapLine, 4>& lines,
                                                     const Eigen::Vector2d& principal_point, int image_width,
                                                     const VerticalLinesSolverOptions& options = {});

// The solver's first stage alone: the rotation (world -> camera) and focal length (px) from the four lines'
// directions; their positions are not used (the 3D "lines" may be directions: a map's dominant horizontal
// directions). Every root, without the position step's checks (no cheirality: the yaw may be off by 180 deg).
struct RotationFocal
{
  Eigen::Matrix3d rotation;
  double focal_px;
};
std::vector<RotationFocal> solveVerticalLinesRotationFocal(const std::array<ImageMapLine, 4>& lines,
                                                           const Eigen::Vector2d& principal_point, int image_width,
                                                           const VerticalLinesSolverOptions& options = {});

// The same with the focal length known (px): three lines (two vertical, one not) fix the pose; up to two solutions
// (line 2's yaw), each the exact solution of the three.
std::vector<CameraModel> solveVerticalLinesPose(const std::array<ImageMapLine, 3>& lines,
                                                const Eigen::Vector2d& principal_point, int image_width,
                                                double focal_px, const VerticalLinesSolverOptions& options = {});
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_VERTICAL_LINES_FOCAL_POSE_H
