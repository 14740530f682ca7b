// 3D lines from noisy points: RANSAC with PCL's sample-consensus line model (pcl::SampleConsensusModelLine,
// pcl::RandomSampleConsensus), then least squares on the inliers. The paper filters the 3D points of each line with
// RANSAC because RGB-D depth is noisy.
//
// For RGB-D edges (fitLine3dToDepthSamples) the refinement uses what is known better than depth: the 2D segment.
// Every point of the 3D line lies in the interpretation plane through the optical centre and the 2D line, and along
// the image line the inverse depth of a 3D line is affine (1/z = alpha + beta t). Fitting alpha, beta to the inliers
// by least squares leaves the line where the sub-pixel 2D edge says across the rays and only estimates depth from
// depth, whose noise (sigma_z = k z^2 on the Xtion) is homoscedastic in inverse depth. An unconstrained 3D fit (PCA,
// Line3dRefinement::kPca) lets the depth noise tilt the line sideways.
#ifndef INSITU_CALIBRATION_LINES_LINE3D_FITTER_H
#define INSITU_CALIBRATION_LINES_LINE3D_FITTER_H

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "insitu_calibration/error.h"
#include "insitu_calibration/lines/depth_sampler.h"
#include "insitu_calibration/lines/rgbd_frame.h"
#include "insitu_calibration/lines/segment_detector.h"

namespace insitu_calibration
{
struct Line3d
{
  Eigen::Vector3d a = Eigen::Vector3d::Zero();  // end points (extent of the inliers), metres
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  int inliers = 0;
  int samples = 0;
  double rms_m = 0.0;  // of the inliers about the line (3D distance)
  // Standard error of the end points predicted from the fit's residuals (the larger of the two; for RGB-D lines
  // along the line of sight, where the depth noise puts it): how far the line may be off its edge. 0: unknown.
  double sigma_m = 0.0;
  // The part of the end points' error that seeing the edge again does not average away, m: the depth
  // registration's uncertainty (DepthSamplerOptions::registration_sigma_px) times the depth's slope at the edge
  // (across it, and along it), along the line of sight. A surface seen at a grazing angle changes depth by a
  // centimetre or more per pixel, so a few tenths of a pixel put its edges millimetres off in every frame alike.
  // 0: none (no registration uncertainty, or not an RGB-D line).
  double sigma_systematic_m = 0.0;
  double range_m = 0.0;  // distance of the segment's midpoint from the sensor when it was measured
  // The sensor's optical centre in the frame of a and b (RGB-D lines: the camera origin, then the map position of
  // the frame); NaN when unknown (fitLine3d). The line map uses it to tell depth errors (along the line of sight,
  // large) from offsets across it (as small as the 2D edge's).
  Eigen::Vector3d sensor = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Segment2d image;     // the RGB segment it comes from (RGB-D lines only)
  double stamp = 0.0;  // of the frame (RGB-D lines only)
  // RGB-D lines (interpretation-plane refinement): a depth step at the edge smaller than the sampler's jump (a window
  // panel a few mm proud of its wall) measured over the inliers, and the line each side's depth gives (side 0: left
  // of the 2D segment, whose direction a -> b follows; NaN where that side had too few readings). One frame rarely
  // tells a step of 2-4 mm at 2 m from the Xtion's noise; the line map pools the evidence over a map line's
  // observations and takes the nearer side's lines (LineMapOptions::depth_step_sigmas).
  DepthStep depth_step;
  std::array<Eigen::Vector3d, 2> side_a = {nanPoint(), nanPoint()};
  std::array<Eigen::Vector3d, 2> side_b = {nanPoint(), nanPoint()};

  Eigen::Vector3d direction() const { return (b - a).normalized(); }
  double length() const { return (b - a).norm(); }
  // Its points (end points, side lines, and the sensor where known) moved into another frame by T.
  void transform(const Eigen::Isometry3d& T);
  static Eigen::Vector3d nanPoint() { return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()); }
};

enum class Line3dRefinement
{
  kInterpretationPlane,  // RGB-D only: inverse depth affine along the 2D segment (default)
  kPca,                  // total least squares of the inliers in 3D (PCL's optimizeModelCoefficients)
};

struct Line3dFitOptions
{
  // RANSAC inlier distance: threshold_m + threshold_per_m2 * z^2, z the median depth of the points (about 3 sigma of
  // the Xtion's depth noise 1.425e-3 z^2, Khoshelham & Elberink 2012).
  double threshold_m = 0.005;
  double threshold_per_m2 = 0.0045;
  int max_iterations = 200;
  double probability = 0.999;
  int min_inliers = 10;
  double min_inlier_ratio = 0.5;  // of the samples
  double min_length_m = 0.1;      // of the inliers' extent
  Line3dRefinement refinement = Line3dRefinement::kInterpretationPlane;
  uint32_t seed = 1;  // of RANSAC's sampling (PCL's generator, reseeded)
  // RGB-D lines: the depth registration's uncertainty, px per axis (Line3d::sigma_systematic_m; the extractor sets
  // it from DepthSamplerOptions::registration_sigma_px).
  double registration_sigma_px = 0.0;
};

// RANSAC + PCA on the inliers, any 3D points. Errors: fewer than min_inliers finite points (kNotEnoughData), no
// consensus with min_inliers / min_inlier_ratio (kNoSolution), inliers shorter than min_length_m (kDegenerate).
// The threshold uses the points' median z (camera-frame points) unless they are not in front of the origin.
Expected<Line3d> fitLine3d(const std::vector<Eigen::Vector3d>& points, const Line3dFitOptions& options);

// The RGB-D edge: depth samples along a 2D segment (depth_sampler.h) back-projected with the camera, RANSAC, then
// the refinement chosen in options. Result in the camera's optical frame. Errors as fitLine3d, and kInvalidInput for
// an invalid camera.
Expected<Line3d> fitLine3dToDepthSamples(const Segment2d& segment, const std::vector<DepthSample>& samples,
                                         const RgbdCamera& camera, const Line3dFitOptions& options);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_LINE3D_FITTER_H
