// Fine-tuning of image lines on the image gradient, the paper's Eq. 8:
//
//   l* = argmax_l  sum_k |grad I(m_k)|,   m_k the points of l inside a region of interest R around the segment
//
// (R: a few px across the segment and extension_px beyond its ends). Each part of a polyline is one such line with
// two degrees of freedom (offset and angle).
//
// How the argmax is found, with sub-pixel accuracy:
// 1. Coarse: the literal Eq. 8 score (the sum of |dI/dn| sampled on the line) on a grid of offsets (0.5 px) and
//    angles (end points moving by 0.5 px) within search_px of the input segment. Finds the right edge when the
//    detection is off by a pixel or two.
// 2. Sub-pixel: the objective with |dI/dn| smoothed across the line by an Epanechnikov kernel of half-width
//    half_width_px. Its stationarity conditions are exactly "the line is the weighted least-squares fit of the
//    per-sample centroids of dI/dn inside the window, weighted by the window's contrast" (a mean-shift step), which
//    is iterated to convergence. For a symmetric edge response (any blur, or none: an area-sampled step) the centroid
//    is the edge position with no bias; the maximum of an interpolated gradient-magnitude image instead locks to the
//    pixel grid (peak locking, ~0.05 px on axis-aligned edges). dI/dn is the derivative of the bilinearly
//    interpolated image along the line's normal, signed by the edge's polarity (so noise averages out instead of
//    accumulating in |.|); on the edge it equals |grad I|.
//    Samples whose window holds another edge (near a corner, a close parallel edge) are left out of the fit: their
//    grey-level step across the window differs from the median step by more than contrast_tolerance; and so are
//    samples whose centroid is more than 3 robust sigmas (at least outlier_px) from the fitted line.
#ifndef INSITU_CALIBRATION_LINES_GRADIENT_REFINER_H
#define INSITU_CALIBRATION_LINES_GRADIENT_REFINER_H

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "insitu_calibration/error.h"

namespace insitu_calibration
{
struct RefinerOptions
{
  double half_width_px = 3.0;    // region of interest across the line, each side (the sub-pixel window)
  double extension_px = 10.0;    // region of interest beyond the end points of a segment / of a polyline
  double search_px = 2.0;        // coarse search across the line, each side (0: skip the coarse stage)
  double sample_step_px = 1.0;   // spacing of the samples m_k along the line
  double profile_step_px = 0.5;  // spacing of the intensity samples across the line
  int max_iterations = 15;
  double convergence_px = 1e-3;     // stop when no point of the part moves more than this
  double min_contrast = 8.0;        // grey levels across the window: weaker samples do not see the edge
  double min_support = 0.5;         // fraction of the samples between the end points that must see the edge
  double outlier_px = 0.5;          // floor of the outlier threshold on per-sample centroids
  double contrast_tolerance = 0.4;  // samples whose step differs from the median step by more (relative) are not
                                    // fitted: their window holds another edge (0: keep all)
  double smoothing_sigma_px = 0.0;  // optional Gaussian smoothing of the image (0: none; noise averages along)
  // Second sub-pixel stage in a narrower window (0: none), from the first stage's line: another edge 1.5-3 px away
  // (a close parallel edge, the far side of a thin strip) biases the centroids of the wide window.
  double polish_half_width_px = 1.5;
  // The grey-level steps of the last window's two flanks (|t| in [w / 2, w]) differ by more than this fraction of
  // the edge's step: another edge inside the window, the part fails (kDegenerate). 0: no test.
  double max_asymmetry = 0.0;
  // A sample of the last window lies off the fine-tuned line when it sees no edge or its centroid is more than
  // max(end_tolerance_px, 3 robust sigmas) from the line: at an end of the part, a run of such samples (at least
  // min_end_run_px long) is where the edge ends or another edge nearly collinear with it takes over
  // (RefinedSegment::off_a_px, off_b_px). 0: not measured.
  double end_tolerance_px = 0.3;
  double min_end_run_px = 3.0;
  // A part whose centroids two lines, split at one sample, fit much better than one (F statistic of the two extra
  // parameters above min_break_f, the two lines more than end_tolerance_px apart at the end of the shorter side, each
  // side at least min_break_px long) spans the junction of two edges: it is fine-tuned again on its longer side, the
  // shorter side reported off the line. 0: not tested.
  double min_break_px = 8.0;
  double min_break_f = 25.0;
  // A part that finds no edge is fitted again as a thin line: a joint, seam or painted line that blur makes a bright
  // or dark bump over the straight baseline between the flanks of a window of half-width thin_line_half_width_px
  // (|t| in [w / 2, w]), with no step across it (mortar and grout seen from a fixed camera metres away: a bump of
  // 2-3 px). The bump's centroid is the line's centre, min_contrast applies to its peak. Off by default (the fixed
  // cameras' parameter thin_lines: docs/measurements.md, "Thin lines").
  bool thin_lines = false;
  double thin_line_half_width_px = 5.0;
};

// A fine-tuned line part.
struct RefinedSegment
{
  Eigen::Vector2d a = Eigen::Vector2d::Zero();  // input end points projected onto the fine-tuned line
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  Eigen::Vector3d line = Eigen::Vector3d::Zero();  // homogeneous, (l0, l1) unit: l . (x, y, 1) = signed distance px
  double contrast = 0.0;                           // mean grey-level step across the edge over the used samples
  double support = 0.0;                            // fraction of the samples between a and b that see the edge
  double residual_px = 0.0;  // RMS of the per-sample centroids about the line (noise of the edge position)
  double shift_px = 0.0;     // largest displacement of a or b by the fine-tuning
  int iterations = 0;
  int samples = 0;         // samples used in the final fit
  double asymmetry = 0.0;  // difference of the last window's flank steps relative to the edge's step
  // Length of the part from a (from b) towards its middle whose samples lie off the fine-tuned line (see
  // RefinerOptions::end_tolerance_px): the edge does not reach the end point there. 0 when it does.
  double off_a_px = 0.0;
  double off_b_px = 0.0;
  bool thin_line = false;  // fitted as a thin line (RefinerOptions::thin_lines): its centre, not an edge
};

struct RefinedPolyline
{
  std::vector<Eigen::Vector2d> points;  // fine-tuned vertices, distorted px
  std::vector<RefinedSegment> parts;    // parts[i] joins points[i] and points[i + 1]
  double max_shift_px = 0.0;            // largest vertex displacement: the stopping test of the paper's iteration
  int failed_parts = 0;                 // parts without an edge (their vertices come from the neighbours, or are kept)
};

// Holds the grey image (float) of one image; fine-tunes any number of segments and polylines on it. Build once
// per image and reuse across the iterations of the calibration. Thread-safe for concurrent const calls.
class LineRefiner
{
public:
  // Errors: empty image or unsupported type (see toGray8 in segment_detector.h; 16UC1 and 32FC1 keep their
  // precision), invalid options.
  static Expected<LineRefiner> create(const cv::Mat& image, const RefinerOptions& options = RefinerOptions());

  // One segment (Eq. 8 with extension_px beyond both ends). A segment across the junction of two edges is fine-tuned
  // on its longer side (min_break_px); the lengths at its ends that are not on the line are off_a_px, off_b_px.
  // Errors: coincident or non-finite end points (kInvalidInput), no edge found under the segment (kNotEnoughData:
  // support below min_support).
  Expected<RefinedSegment> refineSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const;
  // Same, with explicit extensions beyond a and beyond b.
  Expected<RefinedSegment> refineSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double extension_a_px,
                                         double extension_b_px) const;

  // Every part of a polyline (extension_px beyond the two outer ends only). Each new interior vertex is the mean of
  // its projections onto the two fine-tuned parts that share it; a failed part takes no vote. Error when no part
  // finds an edge (kNotEnoughData) or fewer than 2 points (kInvalidInput).
  Expected<RefinedPolyline> refinePolyline(const std::vector<Eigen::Vector2d>& points) const;

  const RefinerOptions& options() const { return options_; }
  int width() const { return image_.cols; }
  int height() const { return image_.rows; }
  const cv::Mat& image() const { return image_; }  // CV_32FC1, grey levels 0..255

private:
  Expected<RefinedSegment> refineSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double extension_a_px,
                                         double extension_b_px, bool find_breaks) const;
  LineRefiner(cv::Mat image, const RefinerOptions& options) : image_(std::move(image)), options_(options) {}
  cv::Mat image_;
  RefinerOptions options_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_GRADIENT_REFINER_H
