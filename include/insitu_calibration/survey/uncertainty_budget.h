// Where a survey calibration's reported pose uncertainty comes from. The one-sigma position and rotation in the
// calibration file (sigma_position_m, sigma_rotation_deg) add three independent parts in quadrature:
//   matched lines   the camera's own least squares and jackknife over its matched lines: what the acceptance checks
//                   use (FixedCameraOptions::max_sigma_*), and what more of the camera's view reduces;
//   map lines       the errors each map line's observations share (Survey's shared_map_errors_in_sigma), which
//                   a camera fitted to those lines takes up: viewing the edges from nearer and from other sides
//                   reduces them;
//   map placement   the whole map's placement in the map frame, the localiser's error averaged over the survey
//                   (Survey::mapPlacement, at the camera: the shift and the turn about the survey's centre); only a
//                   longer survey or a better localiser reduces it.
// The parts are read back from the calibration file's quality extras, so the node's /diagnostics and the offline
// tools say the same thing.
#ifndef INSITU_CALIBRATION_SURVEY_UNCERTAINTY_BUDGET_H
#define INSITU_CALIBRATION_SURVEY_UNCERTAINTY_BUDGET_H

#include <map>
#include <optional>
#include <string>

namespace insitu_calibration
{
struct PoseSigma
{
  double position_m = 0.0;
  double rotation_deg = 0.0;
};

struct UncertaintyBudget
{
  PoseSigma total;  // as reported: sigma_position_m, sigma_rotation_deg
  PoseSigma matched_lines;
  PoseSigma map_lines;
  PoseSigma map_placement;
};

// The quality extras' keys of the parts, which Survey writes and the budget reads (the totals are sigma_position_m
// and sigma_rotation_deg).
constexpr const char* kSigmaLinesPositionKey = "sigma_matched_lines_position_m";
constexpr const char* kSigmaLinesRotationKey = "sigma_matched_lines_rotation_deg";
constexpr const char* kSigmaSharedMapPositionKey = "sigma_shared_map_position_m";
constexpr const char* kSigmaSharedMapRotationKey = "sigma_shared_map_rotation_deg";
constexpr const char* kSigmaPlacementAtCameraKey = "sigma_map_placement_at_camera_m";
constexpr const char* kSigmaPlacementRotationKey = "sigma_map_placement_deg";

// The budget of a calibration file's extras; nullopt without a total or the matched lines' part (a calibration not
// from a survey, or from a version that did not record it). A missing map part is 0.
std::optional<UncertaintyBudget> uncertaintyBudgetOf(const std::map<std::string, double>& extra);

// "matched lines 5.1 mm / 0.100 deg, map lines 8.0 mm / 0.45 deg, map placement 21.0 mm / 0.27 deg"
std::string describeBudget(const UncertaintyBudget& budget);

// "1 sigma in the map frame (as saved): position 23.0 mm, rotation 0.528 deg; of it <describeBudget>", or "" when
// the extras have no budget: what calibrate_survey prints and the node's calibrate service answers after a result.
std::string describeSavedSigma(const std::map<std::string, double>& extra);

// /diagnostics' WARN for a calibration whose saved sigma exceeds the limits: "calibration too uncertain: 1 sigma
// 0.031 m, 0.54 deg (limits 0.030 m, 0.50 deg)", then, where the extras hold the budget, its parts and adviceFor.
std::string describeTooUncertain(const std::map<std::string, double>& extra, double max_position_m,
                                 double max_rotation_deg);

// What reduces the larger part of the position sigma (position_over) or else of the rotation sigma: one sentence
// for an operator, naming the parameters where they are the reason.
std::string adviceFor(const UncertaintyBudget& budget, bool position_over);
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_UNCERTAINTY_BUDGET_H
