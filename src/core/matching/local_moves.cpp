#include "matching/local_moves.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Geometry>

#include "matching/match_refinement.h"
#include "matching/matcher_trace.h"

namespace insitu_calibration
{
namespace matching
{
namespace
{
// The median depth of the matched map lines' midpoints in the camera; 0 without matches.
double medianMatchDepth(const LineMatchResult& result, const std::vector<Segment3d>& map_lines)
{
  const CameraModel& camera = result.calibration.camera;
  std::vector<double> depths;
  for (const auto& m : result.matches)
  {
    const Segment3d& s = map_lines[m.map_line];
    depths.push_back((camera.pose().rotation * (0.5 * (s.a + s.b)) + camera.pose().translation).z());
  }
  if (depths.empty())
    return 0.0;
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  return depths[depths.size() / 2];
}

CameraModel withPose(CameraModel camera, const Eigen::Isometry3d& world_from_camera)
{
  camera.pose() = CameraPose::fromWorldFromCamera(world_from_camera);
  return camera;
}

// Cameras around a result: along the optical axis by +-step with the focal length scaled to keep the scale at the
// median depth Z of the matched lines, sideways (x and y of the camera) by +-step turned towards the point at depth
// Z on the axis, along the world axes by +-step, and the focal length alone by 1 +- focal_relative.
std::vector<CameraModel> hopCameras(const LineMatchResult& result, const std::vector<Segment3d>& map_lines, double step,
                                    double focal_relative)
{
  const CameraModel& camera = result.calibration.camera;
  const double z = medianMatchDepth(result, map_lines);
  std::vector<CameraModel> out;
  if (!(z > 2.0 * step))
    return out;
  const Eigen::Isometry3d world_from_camera = camera.pose().worldFromCamera();
  const Eigen::Matrix3d r = world_from_camera.linear();
  const Eigen::Vector3d c = world_from_camera.translation();
  const Eigen::Vector3d target = c + z * r.col(2);
  for (double sign : {-1.0, 1.0})
  {
    Eigen::Isometry3d moved = world_from_camera;
    moved.translation() = c + sign * step * r.col(2);
    CameraModel dolly = withPose(camera, moved);  // along the axis, focal compensated
    const double scale = (z - sign * step) / z;
    dolly.intrinsics().fx *= scale;
    dolly.intrinsics().fy *= scale;
    out.push_back(dolly);
    for (int axis : {0, 1})  // sideways, looking at the same point
    {
      Eigen::Isometry3d turned = world_from_camera;
      turned.translation() = c + sign * step * r.col(axis);
      const Eigen::Vector3d forward = (target - turned.translation()).normalized();
      turned.linear() = Eigen::Matrix3d(Eigen::Quaterniond::FromTwoVectors(r.col(2), forward)) * r;
      out.push_back(withPose(camera, turned));
    }
    // Pure translations along the world axes: lines parallel to the move keep their images (vertical edges when
    // the height is wrong), so a camera off along them can match most lines and still be wrong.
    for (int axis : {0, 1, 2})
    {
      Eigen::Isometry3d shifted = world_from_camera;
      shifted.translation() = c + sign * step * Eigen::Vector3d::Unit(axis);
      out.push_back(withPose(camera, shifted));
    }
    CameraModel zoom = camera;  // focal length alone
    zoom.intrinsics().fx *= 1.0 + sign * focal_relative;
    zoom.intrinsics().fy *= 1.0 + sign * focal_relative;
    out.push_back(zoom);
  }
  return out;
}
}  // namespace

void traceResult(const LineMatcherOptions& options, const char* what, const LineMatchResult& r, double score)
{
  trace(options, "%s: score %.3f, %zu matches, RMS %.3f px, %s", what, score, r.matches.size(),
        r.calibration.reprojection.rms_px, describeCamera(r.calibration.camera).c_str());
}

bool hopRound(const MatchingProblem& problem, Incumbent* best)
{
  const LineMatcherOptions& options = problem.options;
  bool improved = false;
  std::vector<CameraModel> hops;
  for (double scale : options.hop_scales)
  {
    const auto more =
        hopCameras(best->result, problem.map_lines, scale * options.hop_position_m, scale * options.hop_focal_relative);
    hops.insert(hops.end(), more.begin(), more.end());
  }
  for (const CameraModel& camera : hops)
  {
    auto candidate = refineMatches(problem, camera, options.hop_max_distance_px, {}, best->score);
    if (!candidate)
      continue;
    const double score = rankingScore(candidate->calibration.camera, problem);
    traceResult(options, "hop", *candidate, score);
    if (score < best->score - options.min_score_gain)
    {
      best->score = score;
      best->result = std::move(*candidate);
      best->banned.clear();
      improved = true;
    }
  }
  return improved;
}

bool influenceRound(const MatchingProblem& problem, Incumbent* best)
{
  const LineMatcherOptions& options = problem.options;
  const auto& refinement = best->result.calibration.refinement;
  if (!refinement || refinement->line_influence.size() != best->result.matches.size())
    return false;
  std::vector<size_t> order(best->result.matches.size());
  std::iota(order.begin(), order.end(), 0);
  const auto influence = [&](size_t k) {
    const double v = refinement->line_influence[k];
    return std::isnan(v) ? 0.0 : v;
  };
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return influence(a) > influence(b); });
  const double distance =
      std::max(options.min_distance_px, options.distance_factor * best->result.calibration.reprojection.rms_px);
  for (size_t n = 0; n < order.size() && n < static_cast<size_t>(options.influence_candidates); ++n)
  {
    const LineMatch& m = best->result.matches[order[n]];
    if (influence(order[n]) < options.min_influence)
      break;
    PairSet trial = best->banned;
    trial.insert({m.image_line, m.map_line});
    auto candidate = refineMatches(problem, best->result.calibration.camera, distance, trial);
    if (!candidate)
      continue;
    const double score = rankingScore(candidate->calibration.camera, problem);
    trace(options, "without image line %zu - map line %zu (influence %.3g):", m.image_line, m.map_line,
          influence(order[n]));
    traceResult(options, "  result", *candidate, score);
    if (score < best->score - options.min_score_gain)
    {
      best->score = score;
      best->result = std::move(*candidate);
      best->banned = std::move(trial);
      return true;
    }
  }
  return false;
}
}  // namespace matching
}  // namespace insitu_calibration
