#include "insitu_calibration/survey/view_ambiguity.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "matching/matcher_trace.h"

namespace insitu_calibration
{
namespace
{
constexpr double kDegToRad = M_PI / 180.0;

// An offset and its opposite are one repetition: the sign that makes the largest component positive.
Eigen::Vector3d canonicalSign(const Eigen::Vector3d& v)
{
  Eigen::Index largest = 0;
  v.cwiseAbs().maxCoeff(&largest);
  return v[largest] < 0.0 ? Eigen::Vector3d(-v) : v;
}

// The offsets (canonical sign, across the line) from one matched map line to the map lines parallel to it within
// the period range, each once (within cluster_m).
std::vector<Eigen::Vector3d> parallelOffsets(const Segment3d& line, const std::vector<Segment3d>& map_lines,
                                             const ViewAmbiguityOptions& o)
{
  std::vector<Eigen::Vector3d> out;
  const Eigen::Vector3d d = (line.b - line.a).normalized();
  const double min_cos = std::cos(o.max_parallel_deg * kDegToRad);
  for (const auto& other : map_lines)
  {
    const Eigen::Vector3d e = other.b - other.a;
    if (!(e.norm() > 0.0) || std::abs(d.dot(e.normalized())) < min_cos)
      continue;
    const Eigen::Vector3d to_mid = 0.5 * (other.a + other.b) - line.a;
    const Eigen::Vector3d across = canonicalSign(to_mid - to_mid.dot(d) * d);
    if (across.norm() < o.min_period_m || across.norm() > o.max_period_m)
      continue;
    const bool seen = std::any_of(out.begin(), out.end(),
                                  [&](const Eigen::Vector3d& v) { return (v - across).norm() < o.cluster_m; });
    if (!seen)
      out.push_back(across);
  }
  return out;
}

struct OffsetCluster
{
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  size_t count = 0;    // offsets summed
  size_t support = 0;  // matched lines contributing
  Eigen::Vector3d mean() const { return sum / static_cast<double>(count); }
};

// Whether v is (about) an integer multiple of a shift already chosen: the same repetition, farther.
bool multipleOf(const Eigen::Vector3d& v, const std::vector<RepetitionShift>& chosen, double tolerance)
{
  for (const auto& c : chosen)
  {
    const double k = std::round(v.dot(c.shift) / c.shift.squaredNorm());
    if (k >= 2.0 && (v - k * c.shift).norm() < tolerance)
      return true;
  }
  return false;
}

// A period chosen above may be a multiple of a shorter one that lost on support (a dense map, floor lines of a tiled
// floor, supports every multiple of the tile about as much as the tile, and slightly imprecise lines split the
// tile's own offsets): the camera one tile off would then never be tried (generated office 3003's cam_b was accepted
// one 0.37 m tile off with its four best periods 1.1-1.5 m). The shortest supported period of which a chosen one is
// a multiple is tried too, beyond max_periods.
void appendFundamentals(const std::vector<OffsetCluster>& clusters, const ViewAmbiguityOptions& o,
                        std::vector<RepetitionShift>* out)
{
  const size_t chosen = out->size();
  for (size_t i = 0; i < chosen; ++i)
  {
    const RepetitionShift longer = (*out)[i];
    const OffsetCluster* fundamental = nullptr;
    for (const auto& c : clusters)
      if (c.support >= o.min_support && multipleOf(longer.shift, {{c.mean(), c.support}}, o.cluster_m) &&
          (!fundamental || c.mean().norm() < fundamental->mean().norm()))
        fundamental = &c;
    if (fundamental && !multipleOf(fundamental->mean(), *out, o.cluster_m) &&
        std::none_of(out->begin(), out->end(),
                     [&](const RepetitionShift& r) { return (r.shift - fundamental->mean()).norm() < o.cluster_m; }))
      out->push_back({fundamental->mean(), fundamental->support});
  }
}
}  // namespace

std::vector<RepetitionShift> findRepetitionShifts(const std::vector<Segment3d>& map_lines,
                                                  const std::vector<Segment3d>& matched_map_lines,
                                                  const ViewAmbiguityOptions& o)
{
  std::vector<OffsetCluster> clusters;
  for (const auto& line : matched_map_lines)
  {
    if (!((line.b - line.a).norm() > 0.0))
      continue;
    for (const Eigen::Vector3d& offset : parallelOffsets(line, map_lines, o))
    {
      auto it = std::find_if(clusters.begin(), clusters.end(),
                             [&](const OffsetCluster& c) { return (c.mean() - offset).norm() < o.cluster_m; });
      if (it == clusters.end())
        it = clusters.insert(clusters.end(), OffsetCluster{});
      it->sum += offset;
      ++it->count;
      ++it->support;  // parallelOffsets gives each offset of one line once
    }
  }
  std::sort(clusters.begin(), clusters.end(), [](const OffsetCluster& a, const OffsetCluster& b) {
    return a.support != b.support ? a.support > b.support : a.mean().norm() < b.mean().norm();
  });
  std::vector<RepetitionShift> out;
  for (const auto& c : clusters)
  {
    if (out.size() >= o.max_periods || c.support < o.min_support)
      break;
    if (!multipleOf(c.mean(), out, o.cluster_m))
      out.push_back({c.mean(), c.support});
  }
  appendFundamentals(clusters, o, &out);
  return out;
}

CameraModel shiftedCamera(CameraModel camera, const Eigen::Vector3d& shift, bool compensate_focal, double depth_m)
{
  CameraPose& pose = camera.pose();
  const Eigen::Vector3d axis = pose.rotation.row(2).transpose();
  pose.translation -= pose.rotation * shift;  // centre + shift
  if (compensate_focal && depth_m > 0.0)
  {
    // Moving toward the scene by s makes it look (depth - s) / depth times as far: the focal length shrinks alike.
    const double scale = std::max(0.2, (depth_m - shift.dot(axis)) / depth_m);
    camera.intrinsics().fx *= scale;
    camera.intrinsics().fy *= scale;
  }
  return camera;
}

std::vector<Eigen::Vector3d> neighbourhoodShifts(const CameraModel& camera, double radius_m)
{
  const Eigen::Vector3d axis = camera.pose().rotation.row(2).transpose();
  Eigen::Vector3d side = axis.cross(Eigen::Vector3d::UnitZ());
  side = side.norm() > 1e-6 ? side.normalized() : Eigen::Vector3d(camera.pose().rotation.row(0).transpose());
  const Eigen::Vector3d up = side.cross(axis).normalized();
  std::vector<Eigen::Vector3d> out;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j)
      for (int k = -1; k <= 1; ++k)
        if (const int n = std::abs(i) + std::abs(j) + std::abs(k); n == 1 || n == 3)  // faces and corners
          out.push_back(radius_m * (i * axis + j * side + k * up).normalized());
  return out;
}

namespace
{
struct AlternativeStart
{
  Eigen::Vector3d shift;
  bool compensate = false;
  bool neighbourhood = false;
};

// Median depth (optical-frame z) of the matched map lines' midpoints: the scene the focal compensation keeps in size.
double sceneDepth(const CameraModel& camera, const std::vector<Segment3d>& lines)
{
  std::vector<double> z;
  for (const auto& l : lines)
    z.push_back((camera.pose().rotation * (0.5 * (l.a + l.b)) + camera.pose().translation).z());
  if (z.empty())
    return 0.0;
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  return z[z.size() / 2];
}

double rotationAngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b)
{
  return Eigen::AngleAxisd(a * b.transpose()).angle() / kDegToRad;
}

// Fills the alternative's differences to the accepted camera, and whether they are clear: beyond both the fixed
// limits and difference_sigmas of the accepted result's own uncertainty.
void compare(const CameraCalibration& accepted, AlternativeCamera& alt, const ViewAmbiguityOptions& o)
{
  const CameraModel& a = accepted.camera;
  const CameraModel& b = alt.calibration.camera;
  alt.position_difference_m = (b.pose().center() - a.pose().center()).norm();
  alt.rotation_difference_deg = rotationAngleDeg(b.pose().rotation, a.pose().rotation);
  alt.focal_difference_relative = std::abs(b.intrinsics().fx / a.intrinsics().fx - 1.0);
  const CameraUncertainty& u = accepted.uncertainty;
  const double k = o.difference_sigmas;
  const bool sigmas = u.available;
  alt.clearly_different =
      (alt.position_difference_m > std::max(o.min_position_m, sigmas ? k * u.position_m : 0.0)) ||
      (alt.rotation_difference_deg > std::max(o.min_rotation_deg, sigmas ? k * u.rotation_deg : 0.0)) ||
      (alt.focal_difference_relative > std::max(o.min_focal_relative, sigmas ? k * u.fx / a.intrinsics().fx : 0.0));
}
}  // namespace

ViewAmbiguity findAlternativeCameras(const std::vector<Segment3d>& map_lines,
                                     const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                     const CameraCalibration& accepted,
                                     const std::vector<Segment3d>& accepted_matched_map_lines, int image_width,
                                     int image_height, const LineMatcherOptions& matcher,
                                     const std::vector<double>& map_line_sigmas_m,
                                     const std::vector<double>& final_map_line_sigmas_m, const ViewAmbiguityOptions& o)
{
  const auto start_time = std::chrono::steady_clock::now();
  ViewAmbiguity out;
  out.accepted_matched = accepted_matched_map_lines.size();
  out.accepted_score = explanationScore(map_lines, image_lines, accepted.camera, image_width, image_height, matcher);
  const std::vector<RepetitionShift> shifts = findRepetitionShifts(map_lines, accepted_matched_map_lines, o);
  out.periods = shifts.size();
  for (const auto& r : shifts)
    matching::trace(matcher, "ambiguity: repetition %.3f %.3f %.3f m, beside %zu matched lines", r.shift.x(),
                    r.shift.y(), r.shift.z(), r.support);
  LineMatcherOptions quiet = matcher;
  quiet.trace = nullptr;
  const double depth = sceneDepth(accepted.camera, accepted_matched_map_lines);
  std::vector<AlternativeStart> starts;
  for (const auto& repetition : shifts)
    for (const double sign : {1.0, -1.0})
      for (const bool compensate : {false, true})
        starts.push_back({sign * repetition.shift, compensate, false});
  if (o.neighbourhood_share > 0.0)
    for (const Eigen::Vector3d& shift : neighbourhoodShifts(accepted.camera, o.neighbourhood_share * depth))
      starts.push_back({shift, true, true});
  for (const AlternativeStart& start : starts)
  {
    ++out.tried;
    const auto matched = matchAndCalibrateFrom(
        map_lines, image_lines, shiftedCamera(accepted.camera, start.shift, start.compensate, depth), image_width,
        image_height, quiet, map_line_sigmas_m, {}, final_map_line_sigmas_m);
    if (!matched)
      continue;
    AlternativeCamera alt;
    alt.calibration = matched->calibration;
    alt.shift = start.shift;
    alt.focal_compensated = start.compensate;
    alt.from_neighbourhood = start.neighbourhood;
    alt.matched_lines = matched->matches.size();
    alt.matches = matched->matches;
    alt.correspondences = matched->correspondences;
    alt.score = explanationScore(map_lines, image_lines, alt.calibration.camera, image_width, image_height, matcher);
    compare(accepted, alt, o);
    out.alternatives.push_back(std::move(alt));
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return out;
}

bool explainsAsWell(const AlternativeCamera& alt, const ViewAmbiguity& ambiguity, const ViewAmbiguityOptions& o)
{
  const double margin = alt.from_neighbourhood ? o.neighbourhood_score_margin : o.score_margin;
  return alt.score <= ambiguity.accepted_score + margin &&
         static_cast<double>(alt.matched_lines) >= o.min_matched_share * ambiguity.accepted_matched;
}

std::optional<size_t> sameCameraExplainingBetter(const ViewAmbiguity& ambiguity, const ViewAmbiguityOptions& o)
{
  if (o.better_score_margin <= 0.0)
    return std::nullopt;
  std::optional<size_t> best;
  double best_score = ambiguity.accepted_score - o.better_score_margin;
  for (size_t i = 0; i < ambiguity.alternatives.size(); ++i)
  {
    const AlternativeCamera& alt = ambiguity.alternatives[i];
    if (!alt.clearly_different && alt.matched_lines >= ambiguity.accepted_matched && alt.score <= best_score)
    {
      best = i;
      best_score = alt.score;
    }
  }
  return best;
}

ViewAmbiguity withAcceptedAlternative(const ViewAmbiguity& ambiguity, size_t taken, const CameraCalibration& replaced,
                                      const ViewAmbiguityOptions& o)
{
  const AlternativeCamera& accepted = ambiguity.alternatives.at(taken);
  ViewAmbiguity out = ambiguity;
  out.accepted_score = accepted.score;
  out.accepted_matched = accepted.matched_lines;
  out.replaced_score = ambiguity.accepted_score;
  out.replaced_matched = ambiguity.accepted_matched;
  out.alternatives.clear();
  for (size_t i = 0; i < ambiguity.alternatives.size(); ++i)
    if (i != taken)
    {
      AlternativeCamera alt = ambiguity.alternatives[i];
      alt.dismissed.clear();
      compare(accepted.calibration, alt, o);
      out.alternatives.push_back(std::move(alt));
    }
  AlternativeCamera before;
  before.calibration = replaced;
  before.from_neighbourhood = true;
  before.replaced_result = true;
  before.matched_lines = ambiguity.accepted_matched;
  before.score = ambiguity.accepted_score;
  compare(accepted.calibration, before, o);
  out.alternatives.push_back(std::move(before));
  return out;
}

bool dismissedByOwnChecks(const Status& own_checks)
{
  return !own_checks && own_checks.error().code() == ErrorCode::kNoSolution;
}

std::string ViewAmbiguity::describe() const
{
  char buffer[200];
  std::snprintf(buffer, sizeof(buffer),
                "ambiguity test: %zu repetitions of the map beside the matched lines, %zu matchings redone (%.1f s), "
                "explanation score %.2f",
                periods, tried, seconds, accepted_score);
  std::string out = buffer;
  if (replaced_score >= 0.0)
  {
    std::snprintf(buffer, sizeof(buffer),
                  " (the search's result, %.2f with %zu lines, replaced by a start at the same camera that explains "
                  "the image better)",
                  replaced_score, replaced_matched);
    out += buffer;
  }
  for (const auto& a : alternatives)
    if (a.clearly_different)
    {
      std::snprintf(buffer, sizeof(buffer), "; alternative %.2f m / %.1f deg / %.1f %% away: score %.2f, %zu lines",
                    a.position_difference_m, a.rotation_difference_deg, 100.0 * a.focal_difference_relative, a.score,
                    a.matched_lines);
      out += buffer + (a.dismissed.empty() ? std::string() : " (" + a.dismissed + ")");
    }
  return out;
}

bool isAmbiguityRefusal(const Error& refusal)
{
  const std::string& message = refusal.message();
  return refusal.code() == ErrorCode::kNoSolution &&
         (message.find(kRepeatingViewRefusal) == 0 || message.find(kUndecidedViewRefusal) == 0);
}

Error ambiguityError(const CameraCalibration& accepted, const AlternativeCamera& alt, const ViewAmbiguity& ambiguity)
{
  const Eigen::Vector3d a = accepted.camera.pose().center(), b = alt.calibration.camera.pose().center();
  char buffer[900];
  if (alt.from_neighbourhood)
  {
    std::snprintf(buffer, sizeof(buffer),
                  "%s: a camera at %.2f %.2f %.2f (fx %.1f) explains the image as "
                  "well as the one found at %.2f %.2f %.2f (fx %.1f): explanation score %.2f vs %.2f, %zu vs %zu "
                  "matched lines, %.2f m / %.1f deg / %.1f %% focal length apart (a repeated structure, such as "
                  "shelf rows or door frames, lets the matches slip by one); survey a distinctive feature in the "
                  "camera's view (a rug, a sign, a door, a piece of furniture) and more of its view, or give a "
                  "tighter prior",
                  kUndecidedViewRefusal, b.x(), b.y(), b.z(), alt.calibration.camera.intrinsics().fx, a.x(), a.y(),
                  a.z(), accepted.camera.intrinsics().fx, alt.score, ambiguity.accepted_score, alt.matched_lines,
                  ambiguity.accepted_matched, alt.position_difference_m, alt.rotation_difference_deg,
                  100.0 * alt.focal_difference_relative);
    return Error(ErrorCode::kNoSolution, buffer);
  }
  std::snprintf(buffer, sizeof(buffer),
                "%s: the map lines the camera matched recur every %.2f m along (%.2f %.2f %.2f) (floor "
                "tiles, a row of identical windows, doors or columns), and a camera at %.2f %.2f %.2f (fx %.1f) "
                "explains the image as well as the one found at %.2f %.2f %.2f (fx %.1f): explanation score %.2f vs "
                "%.2f, %zu vs %zu matched lines, %.2f m / %.1f deg / %.1f %% focal length apart; either may be "
                "wrong by whole periods: survey a distinctive feature in the camera's view (a rug, a sign, a door, "
                "a piece of furniture), or give a tighter prior",
                kRepeatingViewRefusal, alt.shift.norm(), alt.shift.x() / alt.shift.norm(),
                alt.shift.y() / alt.shift.norm(), alt.shift.z() / alt.shift.norm(), b.x(), b.y(), b.z(),
                alt.calibration.camera.intrinsics().fx, a.x(), a.y(), a.z(), accepted.camera.intrinsics().fx, alt.score,
                ambiguity.accepted_score, alt.matched_lines, ambiguity.accepted_matched, alt.position_difference_m,
                alt.rotation_difference_deg, 100.0 * alt.focal_difference_relative);
  return Error(ErrorCode::kNoSolution, buffer);
}

}  // namespace insitu_calibration
