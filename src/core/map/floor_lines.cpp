#include "insitu_calibration/map/floor_lines.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include <Eigen/Dense>

namespace insitu_calibration
{
namespace
{
// Where the ray through normalised point p from the camera meets the plane z = floor_height_m (below the camera:
// the floor; above: a ceiling, ceiling_lines.h); false when it does not (the ray runs away from the plane) or
// beyond max_range_m horizontally.
bool floorPoint(const Eigen::Vector2d& p, const Eigen::Isometry3d& T_map_camera, const FloorLineOptions& o,
                Eigen::Vector3d* point)
{
  const Eigen::Vector3d c = T_map_camera.translation();
  const Eigen::Vector3d r = T_map_camera.linear() * Eigen::Vector3d(p.x(), p.y(), 1.0);
  const double height = c.z() - o.floor_height_m;
  if (!(std::abs(height) > 0.0) || !(r.z() * height < 0.0))
    return false;
  const double t = -height / r.z();
  *point = c + t * r;
  return (point->head<2>() - c.head<2>()).norm() <= o.max_range_m;
}

// The candidate's error across its line in the floor plane, per end point the larger: pixel noise normal to the 2D
// segment (random), and the mount's tilt about two horizontal axes and its height (systematic), each propagated by a
// numerical derivative of the ray-plane intersection.
void predictSigmas(const FloorObservation& obs, const Eigen::Isometry3d& T, double focal_px, const FloorLineOptions& o,
                   FloorCandidate* c)
{
  const Eigen::Vector3d along = (c->b - c->a).normalized();
  const Eigen::Vector3d normal = Eigen::Vector3d::UnitZ().cross(along).normalized();
  const Eigen::Vector2d d2 = obs.image_b - obs.image_a;
  const Eigen::Vector2d n2 = Eigen::Vector2d(-d2.y(), d2.x()).normalized();
  const double eps = 1e-6;
  const double tilt = o.tilt_sigma_deg * M_PI / 180.0;
  double random = 0.0, systematic = 0.0;
  FloorLineOptions unlimited = o;
  unlimited.max_range_m = std::numeric_limits<double>::infinity();
  for (int end = 0; end < 2; ++end)
  {
    const Eigen::Vector2d p = end == 0 ? obs.image_a : obs.image_b;
    const Eigen::Vector3d base = end == 0 ? c->a : c->b;
    auto offset = [&](const Eigen::Vector2d& q, const Eigen::Isometry3d& pose) {
      Eigen::Vector3d moved;
      // A ray that leaves the floor under the perturbation: beyond any use, counted as very uncertain.
      if (!floorPoint(q, pose, unlimited, &moved))
        return 1.0 / eps;
      return std::abs((moved - base).dot(normal)) / eps;
    };
    const double pixel = offset(p + eps * n2, T) * o.pixel_sigma_px / focal_px;
    const Eigen::Vector3d h1 = along, h2 = normal;  // horizontal axes through the camera
    Eigen::Isometry3d tilted1 = T, tilted2 = T, raised = T;
    tilted1.linear() = Eigen::AngleAxisd(eps, h1).toRotationMatrix() * T.linear();
    tilted2.linear() = Eigen::AngleAxisd(eps, h2).toRotationMatrix() * T.linear();
    raised.translation().z() += eps;
    const double t1 = offset(p, tilted1) * tilt, t2 = offset(p, tilted2) * tilt;
    const double hs = offset(p, raised) * o.height_sigma_m;
    random = std::max(random, pixel);
    systematic = std::max(systematic, std::sqrt(t1 * t1 + t2 * t2 + hs * hs));
  }
  c->sigma_random_m = random;
  c->sigma_systematic_m = systematic;
}

// A cluster of candidates of one floor line: the weighted (1 / sigma_random^2) line through them in the floor plane.
struct Cluster
{
  std::vector<int> members;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
  double s_min = 0.0, s_max = 0.0;
  double information = 0.0;
};

Eigen::Vector3d normalOf(const Eigen::Vector3d& direction)
{
  return Eigen::Vector3d::UnitZ().cross(direction).normalized();
}

// The weighted total least squares line of the members' segments (each a uniform distribution) and its extent.
void refitCluster(const std::vector<FloorCandidate>& candidates, Cluster* k)
{
  const Eigen::Vector3d reference = candidates[k->members.front()].a;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_xx = Eigen::Matrix3d::Zero();
  double weight = 0.0;
  for (const int m : k->members)
  {
    const auto& c = candidates[m];
    const double w = 1.0 / (c.sigma_random_m * c.sigma_random_m);
    const Eigen::Vector3d mid = 0.5 * (c.a + c.b) - reference, d = c.b - c.a;
    sum += w * mid;
    sum_xx += w * (mid * mid.transpose() + d * d.transpose() / 12.0);
    weight += w;
  }
  const Eigen::Vector3d mean = sum / weight;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(sum_xx / weight - mean * mean.transpose());
  Eigen::Vector3d dir = eig.eigenvectors().col(2);
  dir.z() = 0.0;
  dir.normalize();
  if (dir.dot(k->direction) < 0.0)
    dir = -dir;
  k->point = reference + mean;
  k->direction = dir;
  k->information = weight;
  k->s_min = std::numeric_limits<double>::infinity();
  k->s_max = -k->s_min;
  for (const int m : k->members)
    for (const Eigen::Vector3d& p : {candidates[m].a, candidates[m].b})
    {
      const double s = (p - k->point).dot(dir);
      k->s_min = std::min(k->s_min, s);
      k->s_max = std::max(k->s_max, s);
    }
}

// How far the candidate's end points lie from the cluster's line (the larger), or infinity when its direction or
// extent does not fit.
double clusterDistance(const Cluster& k, const FloorCandidate& c, const FloorLineOptions& o)
{
  const double inf = std::numeric_limits<double>::infinity();
  const Eigen::Vector3d d = (c.b - c.a).normalized();
  if (std::abs(d.dot(k.direction)) < std::cos(o.max_angle_deg * M_PI / 180.0))
    return inf;
  const Eigen::Vector3d n = normalOf(k.direction);
  const double da = std::abs((c.a - k.point).dot(n)), db = std::abs((c.b - k.point).dot(n));
  const double sa = (c.a - k.point).dot(k.direction), sb = (c.b - k.point).dot(k.direction);
  if (std::max({0.0, std::min(sa, sb) - k.s_max, k.s_min - std::max(sa, sb)}) > o.max_gap_m)
    return inf;
  return std::max(da, db);
}

double mergeLimit(const Cluster& k, const FloorCandidate& c, const FloorLineOptions& o)
{
  const double cluster_sigma = k.information > 0.0 ? 1.0 / std::sqrt(k.information) : 0.0;
  return o.merge_sigmas * std::hypot(c.sigma_random_m, cluster_sigma) + o.merge_floor_m;
}

// Greedy clustering, the most precise candidates first; then members that the final line leaves beyond their limit
// are dropped (a slowly drifting chain of an edge off the floor).
std::vector<Cluster> clusterCandidates(const std::vector<FloorCandidate>& candidates, const FloorLineOptions& o)
{
  std::vector<int> order(candidates.size());
  for (size_t i = 0; i < order.size(); ++i)
    order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(),
            [&](int x, int y) { return candidates[x].sigma_random_m < candidates[y].sigma_random_m; });
  std::vector<Cluster> clusters;
  for (const int i : order)
  {
    int best = -1;
    double best_distance = std::numeric_limits<double>::infinity();
    for (size_t j = 0; j < clusters.size(); ++j)
    {
      const double distance = clusterDistance(clusters[j], candidates[i], o);
      if (distance <= mergeLimit(clusters[j], candidates[i], o) && distance < best_distance)
      {
        best = static_cast<int>(j);
        best_distance = distance;
      }
    }
    if (best < 0)
    {
      clusters.emplace_back();
      best = static_cast<int>(clusters.size()) - 1;
      clusters[best].direction = (candidates[i].b - candidates[i].a).normalized();
    }
    clusters[best].members.push_back(i);
    refitCluster(candidates, &clusters[best]);
  }
  for (auto& k : clusters)
  {
    std::vector<int> kept;
    for (const int m : k.members)
      if (clusterDistance(k, candidates[m], o) <= mergeLimit(k, candidates[m], o))
        kept.push_back(m);
    if (!kept.empty() && kept.size() < k.members.size())
    {
      k.members = kept;
      refitCluster(candidates, &k);
    }
  }
  return clusters;
}

// An edge at height e seen by a camera at height h lands on the floor at p' = k p + (1 - k) s across the line (p its
// true offset, s the camera's, k = h / (h - e)): the candidates' offsets regressed on their cameras' offsets have
// the slope beta = -e / (h - e), 0 on the floor. The slope resolves the floor from an edge min_edge_height_m above it
// (beta_min) when its standard error is at most beta_min / (2 confirm_sigmas); it is on the floor when |beta| <=
// beta_min / 2 (both mistakes are confirm_sigmas deviations), and not clearly off it when |beta| - confirm_sigmas
// times its standard error is at most beta_min / 2.
struct SlopeTest
{
  int keyframes = 0;
  int depth_keyframes = 0;  // whose observation's depth put it on the floor
  bool resolved = false;
  bool on_floor = false;
  bool not_off = false;
};

SlopeTest slopeTest(const Cluster& k, const std::vector<FloorCandidate>& candidates, const FloorLineOptions& o)
{
  std::set<int> keyframes, depth_keyframes;
  const Eigen::Vector3d n = normalOf(k.direction);
  double sw = 0.0, sx = 0.0, sy = 0.0, height = 0.0;
  for (const int m : k.members)
  {
    const auto& c = candidates[m];
    keyframes.insert(c.keyframe);
    if (c.depth_on_floor)
      depth_keyframes.insert(c.keyframe);
    const double w = 1.0 / (c.sigma_random_m * c.sigma_random_m);
    sw += w;
    sx += w * c.sensor.dot(n);
    sy += w * (0.5 * (c.a + c.b)).dot(n);
    height += std::abs(c.sensor.z() - o.floor_height_m) / static_cast<double>(k.members.size());
  }
  SlopeTest t;
  if (!(height > o.min_edge_height_m))
    return t;
  t.keyframes = static_cast<int>(keyframes.size());
  t.depth_keyframes = static_cast<int>(depth_keyframes.size());
  const double mx = sx / sw, my = sy / sw;
  double sxx = 0.0, sxy = 0.0;
  for (const int m : k.members)
  {
    const auto& c = candidates[m];
    const double w = 1.0 / (c.sigma_random_m * c.sigma_random_m);
    const double x = c.sensor.dot(n) - mx;
    sxx += w * x * x;
    sxy += w * x * ((0.5 * (c.a + c.b)).dot(n) - my);
  }
  const double beta_min = o.min_edge_height_m / (height - o.min_edge_height_m);
  if (!(sxx > 0.0))
  {
    t.not_off = true;
    return t;
  }
  const double beta = sxy / sxx, beta_sigma = 1.0 / std::sqrt(sxx);
  t.resolved = o.confirm_sigmas * beta_sigma <= 0.5 * beta_min;
  t.on_floor = t.resolved && std::abs(beta) <= 0.5 * beta_min;
  t.not_off = std::abs(beta) - o.confirm_sigmas * beta_sigma <= 0.5 * beta_min;
  return t;
}

// Confirmed: seen from min_keyframes keyframes and on the floor by the slope test, or, with depth_confirmation and
// the slope unresolved (keyframes at one offset across the line), put on the floor by the depth of
// min_depth_keyframes keyframes and not clearly off by the slope.
bool confirmed(const SlopeTest& t, const FloorLineOptions& o)
{
  if (t.keyframes < std::max(2, o.min_keyframes))
    return false;
  if (t.resolved)
    return t.on_floor;
  return o.depth_confirmation && t.not_off && t.depth_keyframes >= std::max(1, o.min_depth_keyframes);
}

// Whether an unresolved cluster continues a confirmed one (extend_confirmed): parallel, both its end points within
// merge_sigmas of the confirmed line (their random errors, plus merge_floor_m).
bool extendsConfirmed(const Cluster& k, const Cluster& confirmed_line, const FloorLineOptions& o)
{
  if (std::abs(k.direction.dot(confirmed_line.direction)) < std::cos(o.max_angle_deg * M_PI / 180.0))
    return false;
  const double limit =
      o.merge_sigmas * std::hypot(1.0 / std::sqrt(k.information), 1.0 / std::sqrt(confirmed_line.information)) +
      o.merge_floor_m;
  const Eigen::Vector3d n = normalOf(confirmed_line.direction);
  for (const double s : {k.s_min, k.s_max})
    if (std::abs((k.point + s * k.direction - confirmed_line.point).dot(n)) > limit)
      return false;
  return true;
}

// Which clusters are confirmed: by confirmed() and, with extend_confirmed, unresolved clusters that are not
// clearly off the floor and continue a cluster confirmed so (no chains).
std::vector<bool> confirmClusters(const std::vector<Cluster>& clusters, const std::vector<FloorCandidate>& candidates,
                                  const FloorLineOptions& o)
{
  std::vector<SlopeTest> tests;
  std::vector<bool> ok;
  for (const auto& k : clusters)
  {
    tests.push_back(slopeTest(k, candidates, o));
    ok.push_back(confirmed(tests.back(), o));
  }
  if (!o.extend_confirmed)
    return ok;
  std::vector<bool> out = ok;
  for (size_t i = 0; i < clusters.size(); ++i)
  {
    const SlopeTest& t = tests[i];
    if (ok[i] || t.resolved || !t.not_off || t.keyframes < std::max(2, o.min_keyframes))
      continue;
    for (size_t j = 0; j < clusters.size() && !out[i]; ++j)
      out[i] = ok[j] && extendsConfirmed(clusters[i], clusters[j], o);
  }
  return out;
}

MapLine toMapLine(const Cluster& k, const std::vector<FloorCandidate>& candidates,
                  const std::vector<Keyframe>& keyframes)
{
  MapLine line;
  line.source = MapLineSource::kFloor;
  line.point = k.point;
  line.direction = k.direction;
  line.s_min = k.s_min;
  line.s_max = k.s_max;
  line.support = static_cast<int>(k.members.size());
  line.reference = k.point;
  line.extreme_lo = line.a();
  line.extreme_hi = line.b();
  // The random part averages over the candidates; the systematic part (tilt, height) does not.
  double systematic = 0.0;
  line.first_stamp = std::numeric_limits<double>::infinity();
  line.last_stamp = -line.first_stamp;
  for (const int m : k.members)
  {
    systematic += candidates[m].sigma_systematic_m / static_cast<double>(k.members.size());
    const double stamp = keyframes[candidates[m].keyframe].stamp;
    line.first_stamp = std::min(line.first_stamp, stamp);
    line.last_stamp = std::max(line.last_stamp, stamp);
  }
  const double sigma = std::hypot(1.0 / std::sqrt(k.information), systematic);
  line.information = 1.0 / (sigma * sigma);
  return line;
}
}  // namespace

FloorDepth floorDepthOf(const std::vector<DepthSample>& samples, const RgbdCamera& camera,
                        const Eigen::Isometry3d& T_map_camera, const FloorLineOptions& o)
{
  if (static_cast<int>(samples.size()) < std::max(1, o.min_depth_samples))
    return FloorDepth::kUnknown;
  FloorLineOptions unlimited = o;
  unlimited.max_range_m = std::numeric_limits<double>::infinity();
  int agree = 0;
  for (const auto& s : samples)
  {
    Eigen::Vector3d on_floor;
    if (!floorPoint(camera.normalize(s.pixel), T_map_camera, unlimited, &on_floor))
      continue;
    const double z = (T_map_camera.inverse() * on_floor).z();
    if (std::abs(s.depth_m - z) <= o.depth_tolerance_m + o.depth_tolerance_per_m2 * z * z)
      ++agree;
  }
  return 2 * agree >= static_cast<int>(samples.size()) ? FloorDepth::kOnFloor : FloorDepth::kOffFloor;
}

bool depthAgreesWithFloor(const std::vector<DepthSample>& samples, const RgbdCamera& camera,
                          const Eigen::Isometry3d& T_map_camera, const FloorLineOptions& o)
{
  return floorDepthOf(samples, camera, T_map_camera, o) != FloorDepth::kOffFloor;
}

bool segmentOnFloor(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double floor_height_m, double tolerance_m)
{
  return std::abs(a.z() - floor_height_m) <= tolerance_m && std::abs(b.z() - floor_height_m) <= tolerance_m;
}

bool depthLineOnFloor(const Line3d& line, const FloorLineOptions& o)
{
  return segmentOnFloor(line.a, line.b, o.floor_height_m, 0.5 * o.min_edge_height_m);
}

bool intersectFloor(const FloorObservation& observation, const Eigen::Isometry3d& T_map_camera, double focal_px,
                    const FloorLineOptions& options, FloorCandidate* candidate)
{
  FloorCandidate c;
  if (!floorPoint(observation.image_a, T_map_camera, options, &c.a) ||
      !floorPoint(observation.image_b, T_map_camera, options, &c.b) || (c.b - c.a).norm() < options.min_length_m)
    return false;
  c.sensor = T_map_camera.translation();
  predictSigmas(observation, T_map_camera, focal_px, options, &c);
  if (!std::isfinite(c.sigma_random_m) || !(c.sigma_random_m > 0.0))
    return false;
  *candidate = c;
  return true;
}

bool heldByMapLine(const MapLine& line, const std::vector<MapLine>& others, double max_angle_deg)
{
  const double limit = std::max(0.03, 3.0 * line.sigma());
  for (const auto& d : others)
  {
    if (std::abs(d.direction.dot(line.direction)) < std::cos(max_angle_deg * M_PI / 180.0))
      continue;
    auto across = [&](const Eigen::Vector3d& p) {
      const Eigen::Vector3d r = p - line.point;
      return (r - r.dot(line.direction) * line.direction).norm();
    };
    const double sa = (d.a() - line.point).dot(line.direction), sb = (d.b() - line.point).dot(line.direction);
    const double overlap = std::min(std::max(sa, sb), line.s_max) - std::max(std::min(sa, sb), line.s_min);
    if (across(d.a()) <= limit && across(d.b()) <= limit && overlap >= 0.5 * line.length())
      return true;
  }
  return false;
}

std::vector<MapLine> confirmFloorLines(const std::vector<Keyframe>& keyframes,
                                       const std::vector<PoseCorrection>& corrections,
                                       const std::vector<MapLine>& depth_lines, const FloorLineOptions& options)
{
  std::vector<MapLine> out;
  if (!options.enabled)
    return out;
  std::vector<FloorCandidate> candidates;
  for (size_t k = 0; k < keyframes.size(); ++k)
  {
    const Eigen::Isometry3d pose = corrections.size() == keyframes.size()
                                       ? corrections[k].apply(keyframes[k].T_map_camera)
                                       : keyframes[k].T_map_camera;
    for (const auto& obs : keyframes[k].floor)
    {
      FloorCandidate c;
      if (!intersectFloor(obs, pose, keyframes[k].focal_px, options, &c))
        continue;
      c.keyframe = static_cast<int>(k);
      c.depth_on_floor = obs.depth_on_floor;
      candidates.push_back(c);
    }
  }
  const std::vector<Cluster> clusters = clusterCandidates(candidates, options);
  const std::vector<bool> ok = confirmClusters(clusters, candidates, options);
  for (size_t i = 0; i < clusters.size(); ++i)
  {
    if (!ok[i])
      continue;
    const MapLine line = toMapLine(clusters[i], candidates, keyframes);
    if (line.sigma() <= options.max_sigma_m && line.length() >= options.min_length_m &&
        !heldByMapLine(line, depth_lines, options.max_angle_deg))
      out.push_back(line);
  }
  return out;
}

}  // namespace insitu_calibration
