#include "matching/hypotheses.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <set>

#include "insitu_calibration/solvers/vertical_lines_focal_pose.h"
#include "matching/matcher_trace.h"

namespace insitu_calibration
{
namespace matching
{
namespace
{
constexpr double kConeSigmas = 3.0;
constexpr double kVerticalMapDeg = 5.0;  // a map line this close to world z is vertical

// The prior's wide cone: where a hypothesis may lie, and how far an image line may appear from where the prior
// predicts it.
struct Cone
{
  Cone(const CameraPrior& p, int width, int height)
      : prior(p),
        camera(cameraFromPrior(p, width, height)),
        axis(p.direction.normalized()),
        max_offset_m(kConeSigmas * p.position_sigma_m),
        max_angle_deg(kConeSigmas * p.direction_sigma_deg),
        fov_min_deg(std::max(10.0, p.horizontal_fov_deg * (1.0 - kConeSigmas * p.fov_sigma_relative))),
        fov_max_deg(std::min(150.0, p.horizontal_fov_deg * (1.0 + kConeSigmas * p.fov_sigma_relative)))
  {
    const double aspect = std::hypot(width, height) / width;  // half diagonal over half width
    half_diagonal_deg = std::atan(aspect * std::tan(0.5 * fov_max_deg * kDegToRad)) / kDegToRad;
  }
  // How far (deg) the direction to a point at `distance_m` may differ from the prior's axis beyond its view.
  double margin(double distance_m) const
  {
    return max_angle_deg + std::atan2(max_offset_m, std::max(0.1, distance_m)) / kDegToRad + 3.0;
  }
  bool contains(const CameraModel& c, int width) const
  {
    const Eigen::Vector3d forward = c.pose().rotation.row(2).transpose();
    const double hfov = 2.0 * std::atan(0.5 * width / c.intrinsics().fx) / kDegToRad;
    const double tilt_of_x = std::asin(std::min(1.0, std::abs(c.pose().rotation(0, 2)))) / kDegToRad;  // roll
    return (c.pose().center() - prior.position).norm() <= max_offset_m &&
           std::acos(std::clamp(forward.dot(axis), -1.0, 1.0)) / kDegToRad <= max_angle_deg && hfov >= fov_min_deg &&
           hfov <= fov_max_deg && tilt_of_x <= std::abs(prior.roll_deg) + 10.0;
  }
  const CameraPrior& prior;
  const CameraModel camera;  // the prior itself
  const Eigen::Vector3d axis;
  const double max_offset_m, max_angle_deg, fov_min_deg, fov_max_deg;
  double half_diagonal_deg = 90.0;
};

double wrapDeg(double a)
{
  return std::remainder(a, 360.0);
}

// Whether an image line may be the image of a vertical line: its direction agrees with the vertical vanishing
// direction at its midpoint for the prior pitched by -3, 0 or +3 sigma, or lies between them (within 6 deg).
bool mayBeVertical(const Cone& cone, const ImageChord& line, int width, int height)
{
  double lowest = 180.0, highest = -180.0;
  for (double pitch : {-1.0, 0.0, 1.0})
  {
    const CameraModel c = cameraFromPrior(cone.prior, width, height, 0.0, pitch * cone.max_angle_deg);
    const Eigen::Vector3d v = c.intrinsics().matrix() * c.pose().rotation * Eigen::Vector3d::UnitZ();
    const Eigen::Vector2d towards =
        std::abs(v.z()) > 1e-9 * v.norm() ? Eigen::Vector2d(v.head<2>() / v.z() - line.mid) : v.head<2>();
    double d = wrapDeg(std::atan2(line.direction.y(), line.direction.x()) / kDegToRad -
                       std::atan2(towards.y(), towards.x()) / kDegToRad);
    d = d > 90.0 ? d - 180.0 : (d < -90.0 ? d + 180.0 : d);  // undirected
    lowest = std::min(lowest, d);
    highest = std::max(highest, d);
  }
  return lowest <= 6.0 && highest >= -6.0;
}

// A map line as the cone may see it: points along it within the cone's widest view.
struct MapCandidate
{
  size_t index;
  bool vertical;
  std::vector<Eigen::Vector3d> points;
};

std::vector<MapCandidate> mapCandidates(const Cone& cone, const std::vector<Segment3d>& map_lines)
{
  const double cos_vertical = std::cos(kVerticalMapDeg * kDegToRad);
  std::vector<MapCandidate> out;
  for (size_t j = 0; j < map_lines.size(); ++j)
  {
    const Segment3d& s = map_lines[j];
    if (!(s.length() > 0.05))
      continue;
    MapCandidate c{j, std::abs((s.b - s.a).normalized().z()) > cos_vertical, {}};
    for (int k = 0; k <= 16; ++k)
    {
      const Eigen::Vector3d p = s.pointAt(k / 16.0);
      const Eigen::Vector3d w = p - cone.prior.position;
      const double distance = w.norm();
      const double angle = std::acos(std::clamp(w.dot(cone.axis) / std::max(1e-9, distance), -1.0, 1.0)) / kDegToRad;
      if (distance > 0.3 && angle <= cone.half_diagonal_deg + cone.margin(distance))
        c.points.push_back(p);
    }
    if (!c.points.empty())
      out.push_back(std::move(c));
  }
  return out;
}

struct Scored
{
  double score;
  CameraModel camera;
};

bool distinctFrom(const CameraModel& c, const std::vector<Scored>& chosen)
{
  return std::all_of(chosen.begin(), chosen.end(), [&](const Scored& s) {
    const double angle = Eigen::AngleAxisd(c.pose().rotation * s.camera.pose().rotation.transpose()).angle();
    return (c.pose().center() - s.camera.pose().center()).norm() > 0.2 || angle > 3.0 * kDegToRad ||
           std::abs(c.intrinsics().fx / s.camera.intrinsics().fx - 1.0) > 0.05;
  });
}
// The best `count` of `scored` (sorted here, best first) distinct from those already chosen, appended to them.
void chooseDistinct(std::vector<Scored>* scored, int count, std::vector<Scored>* chosen)
{
  std::sort(scored->begin(), scored->end(), [](const Scored& a, const Scored& b) { return a.score < b.score; });
  int added = 0;
  for (const Scored& s : *scored)
    if (added < count && distinctFrom(s.camera, *chosen))
      chosen->push_back(s), ++added;
}

// A horizontal direction's azimuth, deg in [0, 180) (a line has no sense), and its length; none for a short or
// steep line.
std::optional<std::pair<double, double>> horizontalAzimuth(const Segment3d& s)
{
  const Eigen::Vector3d d = s.b - s.a;
  if (d.norm() < 0.05 || std::abs(d.normalized().z()) > std::sin(10.0 * kDegToRad))
    return std::nullopt;
  return std::make_pair(std::fmod(std::atan2(d.y(), d.x()) / kDegToRad + 360.0, 180.0), d.norm());
}

// The length-weighted mean azimuth of the lines within 3 deg of a peak's azimuth (doubled angles: 179 and 1 deg
// average to 0): a histogram bin alone leaves up to 1 deg of yaw error in every hypothesis.
Eigen::Vector3d refinedDirection(const std::vector<Segment3d>& map_lines, double peak_deg)
{
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (const Segment3d& s : map_lines)
    if (const auto a = horizontalAzimuth(s); a && std::abs(wrapDeg(2.0 * (a->first - peak_deg))) <= 6.0)
      sum += a->second * Eigen::Vector2d(std::cos(2.0 * a->first * kDegToRad), std::sin(2.0 * a->first * kDegToRad));
  const double azimuth = sum.norm() > 0.0 ? 0.5 * std::atan2(sum.y(), sum.x()) : peak_deg * kDegToRad;
  return Eigen::Vector3d(std::cos(azimuth), std::sin(azimuth), 0.0);
}

// The map's dominant horizontal directions (azimuth histogram of its near-horizontal lines weighted by length, 2 deg
// bins smoothed, peaks at least 15 deg apart holding at least 10 % of the largest, refined), at most four.
std::vector<Eigen::Vector3d> dominantDirections(const std::vector<Segment3d>& map_lines)
{
  constexpr int kBins = 90;
  std::array<double, kBins> histogram{};
  for (const Segment3d& s : map_lines)
    if (const auto a = horizontalAzimuth(s))
      histogram[static_cast<int>(a->first / 2.0) % kBins] += a->second;
  std::array<double, kBins> smooth{};
  for (int b = 0; b < kBins; ++b)
    smooth[b] = histogram[(b + kBins - 1) % kBins] + histogram[b] + histogram[(b + 1) % kBins];
  std::vector<int> order(kBins);
  for (int b = 0; b < kBins; ++b)
    order[b] = b;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return smooth[a] > smooth[b]; });
  std::vector<Eigen::Vector3d> directions;
  std::vector<int> peaks;
  for (int b : order)
  {
    if (smooth[b] <= 0.1 * smooth[order[0]] || directions.size() >= 4)
      break;
    if (std::any_of(peaks.begin(), peaks.end(),
                    [&](int p) { return std::min(std::abs(p - b), kBins - std::abs(p - b)) < 8; }))
      continue;
    peaks.push_back(b);
    directions.push_back(refinedDirection(map_lines, 2.0 * b + 1.0));
  }
  return directions;
}

// Whether an image line points at the vanishing point of world direction d under (R, K), within max_deg.
bool pointsAt(const ImageChord& line, const Eigen::Matrix3d& k_r, const Eigen::Vector3d& d, double max_deg)
{
  const Eigen::Vector3d v = k_r * d;
  const Eigen::Vector2d towards =
      std::abs(v.z()) > 1e-9 * v.norm() ? Eigen::Vector2d(v.head<2>() / v.z() - line.mid) : v.head<2>();
  if (towards.norm() < 1e-9)
    return false;
  return angleBetween(line.direction, towards.normalized()) <= max_deg;
}

Eigen::Matrix3d intrinsicMatrix(double f, const MatchingProblem& problem)
{
  Eigen::Matrix3d k = Eigen::Matrix3d::Identity();
  k(0, 0) = k(1, 1) = f;
  k.topRightCorner<2, 1>() = imageCenter(problem.width, problem.height);
  return k;
}

struct Rotation
{
  double support;  // length of image lines pointing at a vanishing point of the map's directions
  RotationFocal value;
};

// Stage 1: rotation and focal length from directions alone. Two image lines that may be vertical (the vertical
// vanishing point) and two others, each taken as one of the map's dominant horizontal directions, solved by the
// vertical-lines solver's first stage; supported by the image lines pointing at the vertical or a dominant
// direction's vanishing point. The best distinct few in the cone. Both others may take the same direction (their
// vanishing point and the vertical one fix f and the rotation of a tilted camera): a corridor's map has one dominant
// direction, or its cross lines are too few in view for a sample to pick one (then nearly every sample of two
// directions assigns a line wrongly, and a wrong focal length can gather the most support).
std::vector<Rotation> rotationHypotheses(const MatchingProblem& problem, const Cone& cone,
                                         const std::vector<size_t>& vertical, const std::vector<size_t>& other,
                                         const std::vector<Eigen::Vector3d>& directions, std::mt19937& rng)
{
  std::vector<Rotation> found;
  if (vertical.size() < 2 || other.size() < 2 || directions.empty())
    return found;
  const Eigen::Vector2d pp = imageCenter(problem.width, problem.height);
  VerticalLinesSolverOptions options;
  options.min_fov_deg = cone.fov_min_deg;
  options.max_fov_deg = cone.fov_max_deg;
  options.fov_samples = 60;
  std::uniform_int_distribution<size_t> pick_vertical(0, vertical.size() - 1), pick_other(0, other.size() - 1),
      pick_direction(0, directions.size() - 1);
  const auto image = [&](size_t i, const Eigen::Vector3d& d) {
    return ImageMapLine{problem.image[i].first, problem.image[i].last, Segment3d{Eigen::Vector3d::Zero(), d}};
  };
  for (int it = 0; it < problem.options.hypothesis_iterations; ++it)
  {
    const size_t v0 = vertical[pick_vertical(rng)], v1 = vertical[pick_vertical(rng)];
    const size_t o0 = other[pick_other(rng)], o1 = other[pick_other(rng)];
    const size_t d0 = pick_direction(rng), d1 = pick_direction(rng);
    if (v0 == v1 || o0 == o1)
      continue;
    const std::array<ImageMapLine, 4> lines = {image(v0, Eigen::Vector3d::UnitZ()), image(v1, Eigen::Vector3d::UnitZ()),
                                               image(o0, directions[d0]), image(o1, directions[d1])};
    for (const RotationFocal& rf : solveVerticalLinesRotationFocal(lines, pp, problem.width, options))
    {
      const CameraModel probe(Intrinsics{rf.focal_px, rf.focal_px, 0.0, pp.x(), pp.y()}, DivisionModel{0.0, pp},
                              CameraPose{rf.rotation, -rf.rotation * cone.prior.position});
      if (!cone.contains(probe, problem.width))
        continue;
      const Eigen::Matrix3d k_r = intrinsicMatrix(rf.focal_px, problem) * rf.rotation;
      double support = 0.0;
      for (const ImageChord& line : problem.image)
        if (line.length >= 30.0 && (pointsAt(line, k_r, Eigen::Vector3d::UnitZ(), 1.5) ||
                                    std::any_of(directions.begin(), directions.end(),
                                                [&](const Eigen::Vector3d& d) { return pointsAt(line, k_r, d, 1.5); })))
          support += line.length;
      found.push_back({support, rf});
    }
  }
  std::sort(found.begin(), found.end(), [](const Rotation& a, const Rotation& b) { return a.support > b.support; });
  std::vector<Rotation> best;
  for (const Rotation& r : found)
  {
    const bool distinct = std::all_of(best.begin(), best.end(), [&](const Rotation& b) {
      return Eigen::AngleAxisd(r.value.rotation * b.value.rotation.transpose()).angle() > 2.0 * kDegToRad ||
             std::abs(r.value.focal_px / b.value.focal_px - 1.0) > 0.03;
    });
    if (distinct)
      best.push_back(r);
    if (best.size() >= 3)
      break;
  }
  return best;
}

// A putative pair under a known rotation: the image line's plane (world normal through the unknown centre) and a
// point of the map line; the pair says normal . (point - centre) = 0.
struct PlanePair
{
  Eigen::Vector3d normal;
  Eigen::Vector3d point;
  double weight;
  size_t image_line;
};

// Stage 2's pairs: an image line and a map line whose direction's vanishing point it points at (1.5 deg), whose
// plane seen from the prior position passes the map line within the position's 3 sigma.
std::vector<PlanePair> planePairs(const MatchingProblem& problem, const Cone& cone, const RotationFocal& rf,
                                  const std::vector<MapCandidate>& maps)
{
  const Eigen::Matrix3d k_r = intrinsicMatrix(rf.focal_px, problem) * rf.rotation;
  std::vector<PlanePair> pairs;
  for (size_t i = 0; i < problem.image.size(); ++i)
  {
    const ImageChord& line = problem.image[i];
    if (line.length < std::max(30.0, problem.options.min_image_length_px))
      continue;
    const Eigen::Vector3d l = line.first.homogeneous().cross(line.last.homogeneous());
    const Eigen::Vector3d normal = (k_r.transpose() * l).normalized();  // world normal of the back-projected plane
    for (const MapCandidate& m : maps)
    {
      const Segment3d& s = problem.map_lines[m.index];
      if (!pointsAt(line, k_r, (s.b - s.a).normalized(), 1.5))
        continue;
      double best = std::numeric_limits<double>::infinity();
      Eigen::Vector3d nearest;
      for (const Eigen::Vector3d& p : m.points)
        if (const double d = std::abs(normal.dot(p - cone.prior.position)); d < best)
          best = d, nearest = p;
      if (best <= cone.max_offset_m)
        pairs.push_back({normal, nearest, std::exp(-4.5 * std::pow(best / cone.max_offset_m, 2)), i});
    }
  }
  return pairs;
}

// RANSAC samples of three plane pairs per rotation: a view's true pairs can be a few percent of its pairs (each image
// line pairs with every parallel map line in the cone), so that 500 samples missed a corridor camera's centre
// (test_line_hypotheses); about 20 ms per rotation.
constexpr int kCentreSamples = 5000;

// Stage 2: centres from three plane pairs (linear), ranked by the image lines with a pair within 3 cm (an image line
// pairs with every parallel map line in the cone, so counting pairs favours centres where wrong pairs pile up) and
// refined on those pairs; the best `count` (hypothesis_centres) at least 0.2 m apart (a corridor's repeated heights
// leave several).
std::vector<Eigen::Vector3d> centreHypotheses(const std::vector<PlanePair>& pairs, const Cone& cone, int iterations,
                                              size_t count, std::mt19937& rng)
{
  if (pairs.size() < 3)
    return {};
  std::vector<double> weights;
  for (const PlanePair& p : pairs)
    weights.push_back(p.weight);
  std::discrete_distribution<size_t> pick(weights.begin(), weights.end());
  const auto inliers = [&](const Eigen::Vector3d& c) {
    std::vector<size_t> in;
    for (size_t k = 0; k < pairs.size(); ++k)
      if (std::abs(pairs[k].normal.dot(pairs[k].point - c)) < 0.03)
        in.push_back(k);
    return in;
  };
  const auto explained = [&](const std::vector<size_t>& in) {
    std::set<size_t> lines;
    for (size_t k : in)
      lines.insert(pairs[k].image_line);
    return lines.size();
  };
  std::vector<std::pair<size_t, Eigen::Vector3d>> found;
  for (int it = 0; it < iterations; ++it)
  {
    Eigen::Matrix3d a;
    Eigen::Vector3d b;
    for (int r = 0; r < 3; ++r)
    {
      const PlanePair& p = pairs[pick(rng)];
      a.row(r) = p.normal.transpose();
      b(r) = p.normal.dot(p.point);
    }
    if (std::abs(a.determinant()) < 0.05)  // planes nearly sharing a line
      continue;
    const Eigen::Vector3d c = a.partialPivLu().solve(b);
    if ((c - cone.prior.position).norm() <= cone.max_offset_m)
      found.emplace_back(explained(inliers(c)), c);
  }
  std::sort(found.begin(), found.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
  std::vector<Eigen::Vector3d> centres;
  for (const auto& candidate : found)
  {
    Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (size_t k : inliers(candidate.second))
    {
      normal_matrix += pairs[k].normal * pairs[k].normal.transpose();
      rhs += pairs[k].normal * pairs[k].normal.dot(pairs[k].point);
    }
    Eigen::Vector3d c = normal_matrix.ldlt().solve(rhs);
    if (!c.allFinite() || (c - cone.prior.position).norm() > cone.max_offset_m)
      c = candidate.second;
    if (std::all_of(centres.begin(), centres.end(), [&](const Eigen::Vector3d& e) { return (e - c).norm() > 0.2; }))
      centres.push_back(c);
    if (centres.size() >= count)
      break;
  }
  return centres;
}

// The image lines undistorted by `model` (about the image centre, where a hypothesis's camera has its principal
// point): the stages' planes and vanishing points take straight lines.
std::vector<std::vector<Eigen::Vector2d>> undistortedLines(const std::vector<std::vector<Eigen::Vector2d>>& lines,
                                                           const DivisionModel& model)
{
  std::vector<std::vector<Eigen::Vector2d>> out;
  out.reserve(lines.size());
  for (const auto& line : lines)
  {
    std::vector<Eigen::Vector2d> points;
    points.reserve(line.size());
    for (const Eigen::Vector2d& p : line)
      points.push_back(model.undistort(p).value_or(p));
    out.push_back(std::move(points));
  }
  return out;
}

// One distortion's hypotheses (stages 1 and 2 on the image lines undistorted by it), scored on the distorted lines.
void addHypotheses(const MatchingProblem& problem, const Cone& cone, const DivisionModel& distortion,
                   const std::vector<MapCandidate>& maps, const std::vector<Eigen::Vector3d>& directions,
                   std::mt19937& rng, std::vector<Scored>* scored)
{
  const LineMatcherOptions& o = problem.options;
  const std::vector<std::vector<Eigen::Vector2d>> lines = undistortedLines(problem.image_lines, distortion);
  const MatchingProblem straight(problem.map_lines, problem.map_sigmas, lines, problem.width, problem.height, o);
  std::vector<size_t> vertical, other;
  for (size_t i = 0; i < straight.image.size(); ++i)
    if (straight.image[i].length >= std::max(30.0, o.min_image_length_px))
      (mayBeVertical(cone, straight.image[i], straight.width, straight.height) ? vertical : other).push_back(i);
  const std::vector<Rotation> rotations = rotationHypotheses(straight, cone, vertical, other, directions, rng);
  const Eigen::Vector2d pp = imageCenter(problem.width, problem.height);
  const double cap = 0.04 * std::hypot(problem.width, problem.height);
  for (const Rotation& r : rotations)
  {
    const std::vector<PlanePair> pairs = planePairs(straight, cone, r.value, maps);
    const std::vector<Eigen::Vector3d> centres =
        centreHypotheses(pairs, cone, kCentreSamples, static_cast<size_t>(std::max(1, o.hypothesis_centres)), rng);
    trace(o, "hypotheses: lambda %.3g, rotation supported by %.0f px of lines, fx %.1f, %zu plane pairs, %zu centres",
          distortion.lambda, r.support, r.value.focal_px, pairs.size(), centres.size());
    for (const Eigen::Vector3d& centre : centres)
    {
      const CameraModel c(Intrinsics{r.value.focal_px, r.value.focal_px, 0.0, pp.x(), pp.y()}, distortion,
                          CameraPose{r.value.rotation, -r.value.rotation * centre});
      scored->push_back({searchScore(c, problem, 5.0, cap), c});
    }
  }
  trace(o, "hypotheses: lambda %.3g: %zu vertical and %zu other image lines, %zu map directions, %zu rotations",
        distortion.lambda, vertical.size(), other.size(), directions.size(), rotations.size());
}
}  // namespace

std::vector<CameraModel> lineHypotheses(const MatchingProblem& problem, const CameraPrior& prior)
{
  const LineMatcherOptions& o = problem.options;
  const auto started = std::chrono::steady_clock::now();
  const Cone cone(prior, problem.width, problem.height);
  const std::vector<Eigen::Vector3d> directions = dominantDirections(problem.map_lines);
  std::mt19937 rng(12);
  const std::vector<MapCandidate> maps = mapCandidates(cone, problem.map_lines);
  const Eigen::Vector2d pp = imageCenter(problem.width, problem.height);
  // The straight lines' hypotheses keep their starts; the distortions' best add theirs (ranked together, a
  // distorted hypothesis displaced the start that found an undistorted camera: docs/measurements.md).
  std::vector<Scored> straight, distorted;
  for (double corner_px : o.hypothesis_corner_px)
    addHypotheses(problem, cone,
                  DivisionModel{lambdaForCornerDisplacement(pp, problem.width, problem.height, corner_px), pp}, maps,
                  directions, rng, corner_px == 0.0 ? &straight : &distorted);
  std::vector<Scored> chosen;
  chooseDistinct(&straight, o.hypothesis_starts, &chosen);
  chooseDistinct(&distorted, o.hypothesis_distortion_starts, &chosen);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  trace(o, "hypotheses: %zu straight and %zu distorted scored in %.2f s", straight.size(), distorted.size(), seconds);
  std::vector<CameraModel> cameras;
  for (const Scored& s : chosen)
  {
    trace(o, "hypothesis (score %.1f) %s", s.score, describeCamera(s.camera).c_str());
    cameras.push_back(s.camera);
  }
  return cameras;
}

CameraPrior priorAt(const CameraModel& camera, int image_width, const CameraPrior& uncertainty)
{
  CameraPrior p = uncertainty;
  const Eigen::Matrix3d& r = camera.pose().rotation;  // rows: the camera's axes in the world
  p.position = camera.pose().center();
  p.direction = r.row(2).transpose();
  p.horizontal_fov_deg = 2.0 * std::atan(0.5 * image_width / camera.intrinsics().fx) / kDegToRad;
  // cameraFromPrior's roll: the x axis turned about the optical axis from the horizontal.
  Eigen::Vector3d level = p.direction.cross(Eigen::Vector3d::UnitZ());
  if (level.norm() < 1e-6)
    level = Eigen::Vector3d::UnitX();
  level.normalize();
  const Eigen::Vector3d right = r.row(0).transpose();
  p.roll_deg = std::atan2(level.cross(right).dot(p.direction), level.dot(right)) / kDegToRad;
  return p;
}
}  // namespace matching
}  // namespace insitu_calibration
