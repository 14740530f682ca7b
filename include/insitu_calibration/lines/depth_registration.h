// The depth image's misregistration with the RGB image (DepthSamplerOptions::registration_offset_px), estimated from
// the survey itself: the reading at depth pixel q measures the ray of RGB pixel q + s; s is wanted.
//
// Measured at creases, not at occluding edges. Where two planes meet without a depth jump (a wall's corner, a wall on
// the floor, a box's edge) the inverse depth on each side is affine in the (undistorted) image, so a plane fitted to
// each side's readings, away from the edge, and the line where the two planes' inverse depths are equal give the
// crease as the depth image sees it: at the RGB edge moved by -s. The RGB segment gives the same crease in the RGB
// image, so their distance across the segment measures s along its normal; creases of many directions give both
// components (weighted least squares with outliers trimmed). Why creases: at an occluding edge the depth jump's
// location is biased by which side is the foreground (flying pixels mixing the two surfaces, the sensor's window
// straddling the jump, a depth image's nearest-reading rule across surfaces), and the RGB edge's blur and the
// sampler's near-side choice shift it further: an estimator built on them came out 0.4-0.6 px off on the simulator
// (docs/simulator.md, issue 12 diagnosis). At a crease depth is continuous, both sides are read the same way and the
// readings next to the edge (which mix the two surfaces) are left out, so neither side's rule biases the location;
// the planes' extrapolation to the edge is unbiased for zero-mean noise. Lines on a single plane (texture) have no
// crease and are left out by the crease's uncertainty; occluding edges by the crease's distance from the segment.
#ifndef INSITU_CALIBRATION_LINES_DEPTH_REGISTRATION_H
#define INSITU_CALIBRATION_LINES_DEPTH_REGISTRATION_H

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "insitu_calibration/error.h"
#include "insitu_calibration/lines/rgbd_frame.h"
#include "insitu_calibration/lines/segment_detector.h"

namespace insitu_calibration
{
class RgbdLineExtractor;
struct RgbdLineOptions;

struct DepthRegistrationOptions
{
  int band_px = 8;                    // pixels read on each side of a segment ...
  double inner_px = 2.5;              // ... but none closer than this (they mix the two surfaces, and s moves them)
  double end_margin_px = 5.0;         // nor this close to an end point (corners)
  int min_side_pixels = 40;           // readings needed on each side for its plane
  double max_crease_offset_px = 2.0;  // a depth crease farther from the RGB segment: no crease (occluding edge)
  double max_crease_sigma_px = 0.5;   // a crease located less well: left out (nearly coplanar sides: texture)
  double max_side_slope = 0.01;     // a side whose depth changes more per pixel (relative, ~80 deg incidence): left out
  double max_crease_tilt_px = 1.0;  // the depth crease's angle to the segment, as the offset's change over it
  // The RGB edge alone in the band: its grey step (0.5 px apart, averaged along the segment) of at least
  // min_edge_step within edge_core_px of the segment, and none beyond larger than max_side_step_ratio of it.
  double edge_core_px = 2.0;
  double min_edge_step = 2.0;  // grey levels (of 255)
  double max_side_step_ratio = 0.5;
  // The RGB edge's own error, added to each crease's sigma: the same in every frame that sees the crease (texture or
  // a thin joint beside the corner). The creases' scatter about the true offset on the tuning seeds 3001-3004.
  double edge_sigma_px = 0.3;
  double outlier_sigmas = 3.0;  // residuals beyond this many robust sigmas are trimmed from the estimate
  // Observations of one crease (frames that saw it) weigh as one: within same_crease_deg and same_crease_m of the
  // first observation's 3D line (in the map frame).
  double same_crease_deg = 5.0;
  double same_crease_m = 0.05;
  size_t min_creases = 10;     // fewer creases (groups) after trimming: no estimate
  double max_sigma_px = 0.25;  // an estimate less certain than this along any direction is refused
};

// One crease: the depth image's crease lies offset_px along normal from the RGB segment (normal . s = -offset_px).
struct CreaseObservation
{
  Eigen::Vector2d normal = Eigen::Vector2d::UnitY();  // unit, across the RGB segment
  double offset_px = 0.0;
  double sigma_px = 0.0;  // from the two planes' fits and DepthRegistrationOptions::edge_sigma_px
  Eigen::Vector3d point = Eigen::Vector3d::Zero();       // the crease's centre in 3D (camera frame, or map)
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // its direction
};

struct DepthRegistrationEstimate
{
  Eigen::Vector2d offset_px = Eigen::Vector2d::Zero();  // s: DepthSamplerOptions::registration_offset_px
  Eigen::Vector2d sigma_px = Eigen::Vector2d::Zero();   // standard deviations of its x and y
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  size_t creases = 0;       // used (after trimming), a crease seen in several frames counted once
  size_t observations = 0;  // used (after trimming), per frame
  size_t trimmed = 0;       // observations left out as outliers
  size_t frames = 0;        // frames offered
  double scatter = 1.0;     // RMS of the used creases' residuals in units of their own sigmas (the sigmas' scale)
};

// The crease along one segment of a depth image in metres (32FC1, NaN: no reading; depthToMeters) and its RGB image
// in grey (8UC1 or 32FC1; empty: the edge is not checked). camera maps pixels to the pinhole image when it has
// distortion (the planes are affine there). None when the segment is no usable crease (too few readings on a side,
// the crease too far, too uncertain or at an angle to the segment, another edge beside the RGB edge).
std::optional<CreaseObservation> measureCrease(const cv::Mat& depth_m, const cv::Mat& grey, const RgbdCamera& camera,
                                               const Segment2d& segment, const DepthRegistrationOptions& options = {});

// Collects creases over a survey's frames and estimates s from them.
class DepthRegistrationEstimator
{
public:
  explicit DepthRegistrationEstimator(const DepthRegistrationOptions& options = {}) : options_(options) {}

  // The creases of one frame: its depth in metres, its grey image, its RGB segments (fine-tuned, distorted px) and
  // its pose (groups a crease's observations across frames).
  void addFrame(const cv::Mat& depth_m, const cv::Mat& grey, const RgbdCamera& camera,
                const std::vector<Segment2d>& segments,
                const Eigen::Isometry3d& T_map_camera = Eigen::Isometry3d::Identity());
  // The same from an RGB-D frame and its segments as the map's extraction found them (RgbdLineExtractor::extract's
  // or Survey::addRgbdFrame's), its depth read within the extraction's range. Errors: the frame's (validateFrame, no
  // valid depth).
  Status addFrame(const RgbdFrame& frame, const std::vector<Segment2d>& segments, const RgbdLineOptions& options);
  // The same, the segments detected by the extractor. Errors: as above, or the detector's.
  Status addFrame(const RgbdFrame& frame, const RgbdLineExtractor& extractor);

  // The offset with its uncertainty. Errors: fewer than min_creases creases (kNotEnoughData), creases of too few
  // directions or too scattered to give each component within max_sigma_px (kDegenerate); the message says what
  // the survey lacked.
  Expected<DepthRegistrationEstimate> estimate() const;
  // estimate() once the creases have grown by the fraction `growth` since the last time this solved (the first call
  // solves when there is any crease); nullopt when not due. A node asks at every keyframe: solving each time would
  // cost more and more as the survey grows, for an estimate that hardly moves.
  std::optional<Expected<DepthRegistrationEstimate>> estimateWhenGrown(double growth = 0.25);

  const std::vector<CreaseObservation>& creases() const { return creases_; }
  size_t frames() const { return frames_; }

private:
  DepthRegistrationOptions options_;
  std::vector<CreaseObservation> creases_;
  size_t frames_ = 0;
  size_t creases_at_last_estimate_ = 0;  // estimateWhenGrown's last solve
};

// The weighted, trimmed least-squares offset from creases (DepthRegistrationEstimator::estimate's solver).
Expected<DepthRegistrationEstimate> estimateRegistration(const std::vector<CreaseObservation>& creases,
                                                         const DepthRegistrationOptions& options = {});

// How far an offset (the one a survey's depth was read with) lies from an estimate, in standard deviations of the
// estimate (Mahalanobis distance under its covariance; the larger sigma when the covariance is singular).
double registrationDiscrepancySigmas(const DepthRegistrationEstimate& estimate, const Eigen::Vector2d& offset_px);
// What to tell an operator whose survey was read at offset_px when its own creases gave estimate: empty while the
// two agree (within max_sigmas), else what the disagreement costs and which parameters to set.
std::string registrationDisagreementAdvice(const DepthRegistrationEstimate& estimate, const Eigen::Vector2d& offset_px,
                                           double max_sigmas = 3.0);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_DEPTH_REGISTRATION_H
