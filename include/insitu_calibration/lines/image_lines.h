// The 2D half for a fixed camera: detect segments, merge the fragments of each straight 3D edge into one polyline
// (curved under radial distortion), and fine-tune every part on the image gradient (Eq. 8). The fine-tuned
// polylines are LineCorrespondence::image (solvers/correspondences.h) once matched to 3D lines.
#ifndef INSITU_CALIBRATION_LINES_IMAGE_LINES_H
#define INSITU_CALIBRATION_LINES_IMAGE_LINES_H

#include <algorithm>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/lines/gradient_refiner.h"
#include "insitu_calibration/lines/polyline_merger.h"
#include "insitu_calibration/lines/segment_detector.h"

namespace insitu_calibration
{
struct ImageLineOptions
{
  SegmentDetectorOptions detector;
  PolylineMergeOptions merge;
  RefinerOptions refiner;
  double min_part_support = 0.5;  // a line is dropped when fewer than this fraction of its parts found the edge
  // Two fine-tuned parts that disagree at their shared vertex by more than this (their projections of it are apart)
  // lie on different edges (a polyline across a junction, or along two nearly collinear edges): the line is split
  // there. 0: never split.
  double split_gap_px = 0.3;
  // Two adjacent fine-tuned parts whose lines are more than this apart at the far end of either part (beyond the
  // bend of the detected polyline) meet at an angle: they lie on different edges, the line is split between them.
  // 0: never.
  double split_kink_px = 0.5;
  // A thin line's two flanks are detected as two segments that fine-tune to the same centre: of two lines, one thin,
  // lying within this of each other over half the shorter one's length, the shorter is dropped. 0: keep both.
  double duplicate_thin_px = 0.5;
};

struct ImageLine
{
  std::vector<Eigen::Vector2d> detected;  // polyline from the merged detections, before fine-tuning (distorted px)
  std::vector<Eigen::Vector2d> points;    // fine-tuned polyline (distorted px): LineCorrespondence::image
  std::vector<RefinedSegment> parts;      // fine-tuning of each part (parts[i] joins points[i], points[i + 1])
  std::vector<int> fragments;             // indices into ImageLineStats' detected segments
  double length_px = 0.0;
  double contrast = 0.0;  // mean over the parts that found the edge, grey levels

  // A part of it was fine-tuned as a thin line (RefinerOptions::thin_lines).
  bool thin() const
  {
    return std::any_of(parts.begin(), parts.end(), [](const RefinedSegment& p) { return p.thin_line; });
  }
};

struct ImageLineStats
{
  std::vector<Segment2d> segments;  // raw detections
  int polylines = 0;                // after merging
  int lines = 0;                    // after fine-tuning
  int rejected = 0;                 // polylines whose fine-tuning found no edge
  int splits = 0;                   // polylines split where their fine-tuned parts disagree
  int trimmed = 0;                  // lines whose ends were moved in where the edge does not reach them
  int duplicates = 0;               // thin lines found twice (ImageLineOptions::duplicate_thin_px), one dropped
  double detect_ms = 0.0;           // times: CPU time of the calling thread (the cost on one core)
  double merge_ms = 0.0;
  double refine_ms = 0.0;  // includes building the LineRefiner
  std::string note;        // why the result is empty, when it is
};

// Fine-tuned lines of one image. distortion: the current estimate (lambda = 0 with the image centre before the first
// calibration). Errors: empty or unsupported image, non-finite distortion (kInvalidInput). An image without lines
// gives an empty vector and stats->note says why.
Expected<std::vector<ImageLine>> extractImageLines(const cv::Mat& image, const DivisionModel& distortion,
                                                   const ImageLineOptions& options = ImageLineOptions(),
                                                   ImageLineStats* stats = nullptr);
// Same with the distortion of a camera model (the pose and intrinsics are not used).
Expected<std::vector<ImageLine>> extractImageLines(const cv::Mat& image, const CameraModel& camera,
                                                   const ImageLineOptions& options = ImageLineOptions(),
                                                   ImageLineStats* stats = nullptr);

// A thin line is detected along both its flanks (two segments 1-2 px apart) and both fine-tune to its centre: of two
// lines, one of them thin (a part with RefinedSegment::thin_line), that lie within tolerance_px of each other over at
// least half the shorter one's length, the shorter is dropped. Returns how many were dropped (0 for tolerance 0).
int dropDuplicateThinLines(double tolerance_px, std::vector<ImageLine>* lines);

// Fine-tunes the polylines again (the paper's loop: after re-centring the distortion). Lines whose fine-tuning
// fails keep their points. Returns the largest vertex displacement in px.
double refineImageLines(const LineRefiner& refiner, std::vector<ImageLine>& lines);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_LINES_IMAGE_LINES_H
