// Depth along an image segment, taken on the nearer side of a depth discontinuity: an image edge at a depth
// discontinuity is the occluding contour of the front surface, so its 3D points lie on the front surface.
//
// At every sample of the segment the depth is read on a band of pixels across it (band_px each side). The near
// cluster is the set of readings within a jump of the nearest one (max(jump_min_m, jump_ratio z)). Inverse depth,
// affine in the image on a plane, is fitted to the near cluster against the pixels' signed offsets from the edge and
// evaluated on the edge itself: the depth of the front surface at the edge, without the bias of a reading one or two
// pixels away on a slanted surface and without mixing in the background. A step smaller than the jump (a door frame
// 1-2 cm proud of its wall, hidden in the noise of one sample) is found over the whole segment: the two sides'
// depths extrapolated to the edge differ consistently, and the nearer side is taken. Where one side has no depth at all
// near the edge, a nearer surface beyond the gap means the readings may be the background of an unseen near surface:
// no sample there.
#ifndef INSITU_CALIBRATION_LINES_DEPTH_SAMPLER_H
#define INSITU_CALIBRATION_LINES_DEPTH_SAMPLER_H

#include <limits>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "insitu_calibration/error.h"
#include "insitu_calibration/lines/segment_detector.h"

namespace insitu_calibration
{
struct DepthSamplerOptions
{
  double step_px = 2.0;               // between samples along the segment
  int band_px = 4;                    // pixels read on each side of the segment
  double end_margin_px = 3.0;         // no sample this close to an end point (corners mix surfaces)
  double jump_ratio = 0.03;           // a depth discontinuity: readings farther than max(jump_min_m, jump_ratio z)
  double jump_min_m = 0.03;           //   behind the nearest reading
  double max_extrapolation_px = 2.5;  // the near cluster must come this close to the edge
  // Widen the jump by how fast depth grows across the edge on a slanted surface (per side the median neighbour
  // difference along the segment, the smaller side's), times a reading's offset from the nearest one. Without it,
  // on a wall seen at a grazing angle far away, only samples whose deeper side happens to read near keep both
  // sides: a false step of several mm, the same in every frame, and an edge depth biased nearer.
  bool slant_allowance = true;
  // When one side has no reading in the band (no return from a surface seen at a grazing angle, or a projector
  // shadow), the first reading beyond the gap, up to gap_search_px across the edge, tells which: a surface nearer
  // than the readings by more than a jump means the edge may belong to the unseen surface (a chair back's top face
  // between its front face and the wall) and the sample is dropped; otherwise (a shadow on the background) the
  // readings are the near side. 0: no search.
  int gap_search_px = 12;
  // Small steps (below the jump): when the two sides' depths extrapolated to the edge differ consistently along the
  // segment (by more than small_step_sigmas standard errors, and by at least small_step_min_m), the edge takes the
  // nearer side's depth. 0 sigmas: off. A smaller minimum (1 mm) places a window panel 2 mm proud of its wall right
  // without noise but, beyond about 1.5 m, the Xtion's noise keeps such steps under the sigma test of one segment:
  // measured as no gain (docs/measurements.md, "cam_desk's focal-length bias"). The line map can pool the evidence
  // of a map line's observations instead (LineMapOptions::depth_step_sigmas; off, measured there).
  double small_step_sigmas = 5.0;
  double small_step_min_m = 0.004;
  // The depth image's misregistration with the RGB image: the reading at depth pixel q measures the ray of RGB pixel
  // q + registration_offset_px (a few tenths of a pixel to a few pixels on a registered Xtion / Kinect image). A
  // reading taken at the wrong ray puts an edge's depth where the surface is seen at that offset: on a surface seen
  // at a grazing angle centimetres off, the same for every frame, so the map does not average it out. Zero: none.
  Eigen::Vector2d registration_offset_px = Eigen::Vector2d::Zero();
  // Its uncertainty, px per axis (0.5: unknown, the generated Xtions' offsets are 0.3-0.9 px; an estimate's sigma
  // when estimated). It moves an edge's depth by the depth's slope at the edge times it, the same in every frame:
  // Line3d::sigma_systematic_m, which the map line's sigma keeps instead of averaging it away.
  double registration_sigma_px = 0.5;
};

struct DepthSample
{
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // on the segment (the ray its depth measures), px
  double t = 0.0;                                   // (pixel - a) . (b - a) / |b - a|^2, about [0, 1]
  double depth_m = 0.0;                             // optical-frame z of the front surface at the edge
  bool discontinuity = false;                       // far readings were present and ignored
  // How the depth changes across the edge on each side of it (m per px of offset, signed; left: negative offsets;
  // 0 where a side gave no slope): a registration error of e px across moves depth_m by about e times the slope of
  // the side it moves into. Single samples' slopes are noisy: the fit takes their median along the segment.
  Eigen::Vector2d depth_slope_m_per_px = Eigen::Vector2d::Zero();
  // Each side's own inverse depth extrapolated to the edge (left, right; 1/m): what a small step between the sides
  // (measureDepthStep) is measured from. NaN where a side has fewer than two readings, or a farther surface was seen
  // (a step larger than the jump, decided per sample).
  Eigen::Vector2d side_inverse_depth = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
};

// A depth step across an edge smaller than the jump, measured along it: the difference of the two sides' depths at
// the edge (DepthSample::side_inverse_depth), averaged over the samples that have both.
struct DepthStep
{
  double left_nearer_by_m = 0.0;  // the right side's depth minus the left's (positive: the left side is nearer), m
  double sigma_m = 0.0;           // its standard error, m
  int samples = 0;                // with both sides; 0: not measured (fewer than 8)
};
DepthStep measureDepthStep(const std::vector<DepthSample>& samples);

// Depth image -> 32FC1 metres, NaN where there is no measurement (0 in 16UC1, 0/NaN/inf in 32FC1, or outside
// [min_range_m, max_range_m]). Errors: empty image, type other than 16UC1 (mm) / 32FC1 (m) (kInvalidInput), no
// valid pixel at all (kNotEnoughData: "all zero or NaN").
Expected<cv::Mat> depthToMeters(const cv::Mat& depth, double min_range_m = 0.0,
                                double max_range_m = std::numeric_limits<double>::infinity());

// Samples along the segment (in 32FC1 metres from depthToMeters). Samples without a usable near depth are left out:
// the result may be empty.
std::vector<DepthSample> sampleDepthAlongSegment(const cv::Mat& depth_m, const Segment2d& segment,
                                                 const DepthSamplerOptions& options = DepthSamplerOptions());

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_DEPTH_SAMPLER_H
