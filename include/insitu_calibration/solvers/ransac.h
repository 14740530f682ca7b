// Robust DLT over line correspondences: RANSAC with minimal sets of 6 lines (7 with distortion), MSAC scoring of each
// line by the RMS distance of its world points' projections to its image polyline, and local optimisation (LO-RANSAC:
// a re-fit on all inliers whenever a better hypothesis appears). Point correspondences, when present, join every fit.
#ifndef INSITU_CALIBRATION_SOLVERS_RANSAC_H
#define INSITU_CALIBRATION_SOLVERS_RANSAC_H

#include <vector>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/solvers/correspondences.h"
#include "insitu_calibration/solvers/dlt.h"

namespace insitu_calibration
{
struct RansacOptions
{
  double inlier_threshold_px = 3.0;  // a line is an inlier when its RMS point-to-line error is below this
  double confidence = 0.999;
  int max_iterations = 2000;
  unsigned seed = 1;
  bool local_optimization = true;
};

struct RansacResult
{
  std::vector<bool> inliers;  // per line
  size_t inlier_count = 0;
  int iterations = 0;
  CameraModel camera;  // the best hypothesis after local optimisation (linear, no principal-point iteration)
};

// RMS distance in px of a line's world points (projected) to its image polyline; infinity when one cannot project.
double lineError(const CameraModel& camera, const LineCorrespondence& line);

// The fewest lines DLT-Lines solves from: 6, 7 with distortion. RANSAC's sample size and the robust selection's floor.
size_t minimalLineCount(const DltOptions& dlt);

// A camera's consensus over the lines, as RANSAC and the robust selection (calibration.h) both judge it: the MSAC
// score, the sum over lines of min(e^2, t^2) with e = lineError (a line that cannot project counts t^2), and the
// inliers, e < t.
struct LineConsensus
{
  double score = 0.0;
  std::vector<bool> inliers;
  size_t inlier_count = 0;
};
LineConsensus scoreLines(const CameraModel& camera, const CorrespondenceSet& data, double threshold);

Expected<RansacResult> ransacDlt(const CorrespondenceSet& data, const DltOptions& dlt, const RansacOptions& options);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_RANSAC_H
