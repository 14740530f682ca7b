// The linear stage for dense noisy polylines (issue 13). DLT-Lines pairs every world point with every part (two
// consecutive image points) of a polyline; with many noisy image points a part's direction is poor and the linear
// lambda goes wild. Here lambda comes first from the straightness of all polylines together (the plumb-line
// constraint of the division model: a 3D line's image is straight once undistorted), then every polyline is
// undistorted and replaced by its fitted straight line, and the pin-hole DLT runs on those lines.
#ifndef INSITU_CALIBRATION_SOLVERS_PLUMB_LINE_H
#define INSITU_CALIBRATION_SOLVERS_PLUMB_LINE_H

#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/solvers/correspondences.h"
#include "insitu_calibration/solvers/dlt.h"

namespace insitu_calibration
{
struct PlumbLineEstimate
{
  double lambda = 0.0;  // 1/px^2 around `center`
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double image_sigma_px = 0.0;  // the image points' scatter about their straight lines (noise estimate)
  size_t polylines = 0;         // polylines of 3 or more points used
};

// lambda minimising the points' distances to their polylines' own straight lines (after undistortion about
// `center`, measured back in distorted px), searched over the range in which the model stays one-to-one over the
// image. Needs at least two polylines of 3 or more points.
Expected<PlumbLineEstimate> estimatePlumbLineLambda(const std::vector<std::vector<Eigen::Vector2d>>& polylines,
                                                    const Eigen::Vector2d& center, int image_width, int image_height);

// The image side of a polyline fitted as one line: its points undistorted by `distortion` and replaced by the ends of
// their total-least-squares line (the first and last point projected onto it). Undistorted px.
std::vector<Eigen::Vector2d> straightenPolyline(const std::vector<Eigen::Vector2d>& polyline,
                                                const DivisionModel& distortion);

// The whole set straightened: every line's polyline by straightenPolyline, every point undistorted (plumb lines are
// dropped). A pin-hole solver on it gives a camera whose distortion is `distortion`.
CorrespondenceSet straightenCorrespondences(const CorrespondenceSet& data, const DivisionModel& distortion);

// lambda from all line polylines of the set about `center` (estimatePlumbLineLambda).
Expected<PlumbLineEstimate> estimatePlumbLineLambda(const CorrespondenceSet& data, const Eigen::Vector2d& center);

// The plumb-line linear stage: lambda from all polylines, then the pin-hole DLT (with the options' method and
// normalisation) on the straightened lines and the undistorted points. The camera carries lambda about the image
// centre.
Expected<DltResult> solvePlumbLineDlt(const CorrespondenceSet& data, const DltOptions& options);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_PLUMB_LINE_H
