#include "insitu_calibration/survey/uncertainty_budget.h"

#include <cmath>
#include <cstdio>

namespace insitu_calibration
{
namespace
{
double valueOr(const std::map<std::string, double>& extra, const char* key, double fallback)
{
  const auto it = extra.find(key);
  return it != extra.end() && std::isfinite(it->second) ? it->second : fallback;
}

std::string format(const PoseSigma& s)
{
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.1f mm / %.3f deg", 1000.0 * s.position_m, s.rotation_deg);
  return buffer;
}
}  // namespace

std::optional<UncertaintyBudget> uncertaintyBudgetOf(const std::map<std::string, double>& extra)
{
  const double nan = std::nan("");
  UncertaintyBudget b;
  b.total = {valueOr(extra, "sigma_position_m", nan), valueOr(extra, "sigma_rotation_deg", nan)};
  b.matched_lines = {valueOr(extra, kSigmaLinesPositionKey, nan), valueOr(extra, kSigmaLinesRotationKey, nan)};
  if (!std::isfinite(b.total.position_m) || !std::isfinite(b.total.rotation_deg) ||
      !std::isfinite(b.matched_lines.position_m) || !std::isfinite(b.matched_lines.rotation_deg))
    return std::nullopt;
  b.map_lines = {valueOr(extra, kSigmaSharedMapPositionKey, 0.0), valueOr(extra, kSigmaSharedMapRotationKey, 0.0)};
  b.map_placement = {valueOr(extra, kSigmaPlacementAtCameraKey, 0.0), valueOr(extra, kSigmaPlacementRotationKey, 0.0)};
  return b;
}

std::string describeBudget(const UncertaintyBudget& budget)
{
  return "matched lines " + format(budget.matched_lines) + ", map lines " + format(budget.map_lines) +
         ", map placement " + format(budget.map_placement);
}

std::string describeSavedSigma(const std::map<std::string, double>& extra)
{
  const auto budget = uncertaintyBudgetOf(extra);
  if (!budget)
    return "";
  char buffer[96];
  std::snprintf(buffer, sizeof(buffer), "1 sigma in the map frame (as saved): position %.1f mm, rotation %.3f deg",
                1000.0 * budget->total.position_m, budget->total.rotation_deg);
  return std::string(buffer) + "; of it " + describeBudget(*budget);
}

std::string adviceFor(const UncertaintyBudget& budget, bool position_over)
{
  const auto part = [&](const PoseSigma& s) { return position_over ? s.position_m : s.rotation_deg; };
  const double lines = part(budget.matched_lines), map = part(budget.map_lines), placement = part(budget.map_placement);
  if (lines >= map && lines >= placement)
    return "most of it is the matched lines': survey more of the camera's view (edges in every part of the image and "
           "at other depths), so that more lines match";
  if (map >= placement)
    return "most of it is the map lines' own errors, which all their observations share: survey the edges this "
           "camera sees from nearer (depth errors grow with the square of the distance) and from other directions, "
           "or measure the Xtion's depth registration once (calibrate_survey --depth-registration estimate) and set "
           "depth_registration/x_px, y_px and sigma_px to it (an unmeasured registration's 0.5 px uncertainty is often "
           "most of this part)";
  return "most of it is the map's placement, the localiser's error averaged over the survey (localization_sigma_m, "
         "localization_sigma_deg): survey longer, or set them to the localiser's measured error if it is smaller";
}

std::string describeTooUncertain(const std::map<std::string, double>& extra, double max_position_m,
                                 double max_rotation_deg)
{
  const double position = valueOr(extra, "sigma_position_m", 0.0), rotation = valueOr(extra, "sigma_rotation_deg", 0.0);
  char buffer[160];
  std::snprintf(buffer, sizeof(buffer), "calibration too uncertain: 1 sigma %.3f m, %.2f deg (limits %.3f m, %.2f deg)",
                position, rotation, max_position_m, max_rotation_deg);
  std::string out = buffer;
  if (const auto budget = uncertaintyBudgetOf(extra))
    out += "; of it " + describeBudget(*budget) + "; " + adviceFor(*budget, position > max_position_m);
  return out;
}
}  // namespace insitu_calibration
