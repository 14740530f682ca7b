// How far the survey's map may be off in the map frame: the localiser's error, a stationary Gauss-Markov process
// per recording (an AMCL-like localiser wanders slowly), averaged over keyframes. The map adjustment places the
// survey where the localiser's priors average to; what is left is that average's error. Recordings are not taken as
// independent of each other: a localiser errs alike where it passes again (its own map's errors there), so their
// averages are combined with the bound that holds for any correlation between them.
// The keyframes that observed a camera's lines average over fewer samples than the whole survey, but the adjustment
// ties them to the rest: on simulated surveys a camera's error followed the map's error where its lines are, after the
// adjustment, whose size the whole survey's placement predicted and the observers' own overstated 1.2-1.7 times
// (docs/survey_calibration.md, "The placement where the camera's lines are"); calibrate_survey prints both.
#ifndef INSITU_CALIBRATION_SURVEY_MAP_PLACEMENT_H
#define INSITU_CALIBRATION_SURVEY_MAP_PLACEMENT_H

#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/lines/line_map.h"
#include "insitu_calibration/map/line_map_adjustment.h"

namespace insitu_calibration
{
// The map's placement in the map frame: how far the map may be off, as a shift and a turn about centre.
struct MapPlacementUncertainty
{
  double sigma_m = 0.0;                              // per horizontal axis
  double sigma_deg = 0.0;                            // yaw
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // the keyframes' mean position
  size_t keyframes = 0;                              // averaged over

  // At a point: the shift in both axes and the turn times the point's horizontal distance from centre (m, one sigma
  // of the horizontal offset's length).
  double atPoint(const Eigen::Vector3d& point) const;
};

// The localiser's error model: sigmas per keyframe and its correlation time (0: independent keyframes).
struct LocaliserErrorModel
{
  double sigma_m = 0.0;
  double sigma_deg = 0.0;
  double correlation_s = 0.0;
};

// Each keyframe's recording (0, 1, ...): a new one where a keyframe starts one (Keyframe::starts_recording) or the
// clock did not move forward.
std::vector<int> recordingOf(const std::vector<Keyframe>& keyframes);

// The standard deviation of the mean of a unit stationary process with correlation exp(-|dt| / correlation_s) over
// the given stamps (ascending), exactly: sqrt(sum_ij rho_ij) / n. 1 for one stamp; 0 without any.
double meanErrorScale(const std::vector<double>& stamps, double correlation_s);

// The placement of the mean over the selected keyframes (indices into keyframes, ascending). Per recording
// meanErrorScale of its selected keyframes; across recordings the bound sum_r (n_r / n) scale_r (any correlation
// between them).
MapPlacementUncertainty placementOverKeyframes(const std::vector<Keyframe>& keyframes,
                                               const std::vector<size_t>& selected, const LocaliserErrorModel& model);

// The keyframes that observed the lines: those whose stamp one of a line's observations carries, and for a line
// without observations (on the floor, triangulated, on the ceiling) those from its first to its last stamp.
// Ascending, each once.
std::vector<size_t> keyframesObserving(const std::vector<Keyframe>& keyframes,
                                       const std::vector<const MapLine*>& lines);
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_MAP_PLACEMENT_H
