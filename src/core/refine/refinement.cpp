#include "insitu_calibration/refine/refinement.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>

#include <Eigen/Dense>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <glog/logging.h>
#include <Eigen/Geometry>

#include "insitu_calibration/metrics.h"
#include "insitu_calibration/refine/noise_model.h"

namespace insitu_calibration
{
namespace
{
// Parameter blocks: focal [fx, fy], principal point [cx, cy], skew [s], distortion [k] with lambda = k / r_ref^2
// (k is O(0.1) where lambda is O(1e-7)), rotation update delta (angle-axis, R = exp(delta) R0), optical centre C.
struct Parameters
{
  double focal[2];
  double principal[2];
  double skew[1];
  double distortion[1];
  double delta[3] = {0.0, 0.0, 0.0};
  double center[3];
};

struct Projector
{
  Eigen::Matrix3d r0;
  double r_ref2;
  bool single_focal;

  // World point -> homogeneous undistorted pixel relative to the principal point.
  template <typename T>
  void undistortedHomogeneous(const T* focal, const T* skew, const T* delta, const T* center,
                              const Eigen::Vector3d& world, T* u) const
  {
    const T x[3] = {T(world.x()), T(world.y()), T(world.z())};
    undistortedHomogeneous(focal, skew, delta, center, x, u);
  }
  template <typename T>
  void undistortedHomogeneous(const T* focal, const T* skew, const T* delta, const T* center, const T* world,
                              T* u) const
  {
    T d[3] = {world[0] - center[0], world[1] - center[1], world[2] - center[2]};
    T rotated[3];
    for (int i = 0; i < 3; ++i)
      rotated[i] = T(r0(i, 0)) * d[0] + T(r0(i, 1)) * d[1] + T(r0(i, 2)) * d[2];
    T xc[3];
    ceres::AngleAxisRotatePoint(delta, rotated, xc);
    const T fy = single_focal ? focal[0] : focal[1];
    u[0] = focal[0] * xc[0] + skew[0] * xc[1];
    u[1] = fy * xc[1];
    u[2] = xc[2];
  }

  // World point -> distorted pixel; false behind the camera or outside the division model's domain.
  template <typename T>
  bool operator()(const T* focal, const T* principal, const T* skew, const T* distortion, const T* delta,
                  const T* center, const Eigen::Vector3d& world, T* pixel) const
  {
    T u[3];
    undistortedHomogeneous(focal, skew, delta, center, world, u);
    if (!(u[2] > T(1e-9)))
      return false;
    // Undistorted pixel relative to the distortion centre (the principal point).
    const T ux = u[0] / u[2];
    const T uy = u[1] / u[2];
    const T lambda = distortion[0] / T(r_ref2);
    const T disc = T(1.0) - T(4.0) * lambda * (ux * ux + uy * uy);
    if (!(disc > T(0.0)))
      return false;
    const T factor = T(2.0) / (T(1.0) + sqrt(disc));
    pixel[0] = principal[0] + ux * factor;
    pixel[1] = principal[1] + uy * factor;
    return true;
  }
};

// Signed distance of a world point's projection to the infinite line of one image part.
struct PointToPartResidual
{
  Projector projector;
  Eigen::Vector3d world;
  Eigen::Vector2d a;
  Eigen::Vector2d normal;
  double weight = 1.0;

  template <typename T>
  bool operator()(const T* focal, const T* principal, const T* skew, const T* distortion, const T* delta,
                  const T* center, T* residual) const
  {
    T m[2];
    if (!projector(focal, principal, skew, distortion, delta, center, world, m))
      return false;
    residual[0] = T(weight) * (T(normal.x()) * (m[0] - T(a.x())) + T(normal.y()) * (m[1] - T(a.y())));
    return true;
  }
};

// Distance of an observed distorted image point to the distorted image of the 3D line through world points a, b:
// the point is undistorted, its distance to the projected straight line measured in undistorted pixels, and scaled
// back by the division model's local scale 1 + lambda r_d^2 (exact across the radial direction, first order along it).
struct ImagePointToLineResidual
{
  Projector projector;
  Eigen::Vector3d world_a;
  Eigen::Vector3d world_b;
  Eigen::Vector2d image;
  double weight = 1.0;

  template <typename T>
  bool operator()(const T* focal, const T* principal, const T* skew, const T* distortion, const T* delta,
                  const T* center, T* residual) const
  {
    T ua[3];
    T ub[3];
    projector.undistortedHomogeneous(focal, skew, delta, center, world_a, ua);
    projector.undistortedHomogeneous(focal, skew, delta, center, world_b, ub);
    return distance(ua, ub, image, weight, principal, distortion, projector.r_ref2, residual);
  }

  // The residual from the two projections (shared with JointImageResidual).
  template <typename T>
  static bool distance(const T* ua, const T* ub, const Eigen::Vector2d& image, double weight, const T* principal,
                       const T* distortion, double r_ref2, T* residual)
  {
    // Homogeneous image line through both projections (relative to the principal point), valid for any depth sign.
    const T l0 = ua[1] * ub[2] - ua[2] * ub[1];
    const T l1 = ua[2] * ub[0] - ua[0] * ub[2];
    const T l2 = ua[0] * ub[1] - ua[1] * ub[0];
    const T norm = sqrt(l0 * l0 + l1 * l1);
    if (!(norm > T(0.0)))
      return false;
    const T dx = T(image.x()) - principal[0];
    const T dy = T(image.y()) - principal[1];
    const T scale = T(1.0) + distortion[0] / T(r_ref2) * (dx * dx + dy * dy);
    if (!(scale > T(0.0)))
      return false;
    residual[0] = T(weight) * (l0 * (dx / scale) + l1 * (dy / scale) + l2) / norm * scale;
    return true;
  }
};

// kJoint's 3D line, a free parameter q of 4 entries: its ends a = a0 + q0 e1 + q1 e2 and b = b0 + q2 e1 + q3 e2
// move across the line as fitted to the world points (e1, e2 perpendicular to it); along it they cannot move.
struct LineFrame
{
  Eigen::Vector3d a0;
  Eigen::Vector3d b0;
  Eigen::Vector3d e1;
  Eigen::Vector3d e2;

  template <typename T>
  void ends(const T* q, T* a, T* b) const
  {
    for (int i = 0; i < 3; ++i)
    {
      a[i] = T(a0(i)) + q[0] * T(e1(i)) + q[1] * T(e2(i));
      b[i] = T(b0(i)) + q[2] * T(e1(i)) + q[3] * T(e2(i));
    }
  }
};

// An image point to the distorted image of the free 3D line (ImagePointToLineResidual with the line as parameter).
struct JointImageResidual
{
  Projector projector;
  LineFrame frame;
  Eigen::Vector2d image;

  template <typename T>
  bool operator()(const T* focal, const T* principal, const T* skew, const T* distortion, const T* delta,
                  const T* center, const T* line, T* residual) const
  {
    T a[3], b[3], ua[3], ub[3];
    frame.ends(line, a, b);
    projector.undistortedHomogeneous(focal, skew, delta, center, a, ua);
    projector.undistortedHomogeneous(focal, skew, delta, center, b, ub);
    return ImagePointToLineResidual::distance(ua, ub, image, 1.0, principal, distortion, projector.r_ref2, residual);
  }
};

// A world point's distance to the free 3D line (its two components across the fitted line), in m times `weight`
// (image sigma / world sigma: px of equal noise).
struct WorldPointToLineResidual
{
  LineFrame frame;
  Eigen::Vector3d world;
  double weight;

  template <typename T>
  bool operator()(const T* line, T* residual) const
  {
    T a[3], b[3];
    frame.ends(line, a, b);
    const T d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const T norm = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(norm > T(0.0)))
      return false;
    T v[3] = {T(world.x()) - a[0], T(world.y()) - a[1], T(world.z()) - a[2]};
    const T along = (v[0] * d[0] + v[1] * d[1] + v[2] * d[2]) / (norm * norm);
    for (int i = 0; i < 3; ++i)
      v[i] -= along * d[i];
    residual[0] = T(weight) * (v[0] * T(frame.e1.x()) + v[1] * T(frame.e1.y()) + v[2] * T(frame.e1.z()));
    residual[1] = T(weight) * (v[0] * T(frame.e2.x()) + v[1] * T(frame.e2.y()) + v[2] * T(frame.e2.z()));
    return true;
  }
};

// Per line: the 3D line its image residuals use (fitted to the world points for kJoint, the first and last world
// points otherwise) and, when its world points are noisy under kJoint, the free line's frame, parameters and the
// weight of its world residuals.
struct LineModel
{
  FittedLine3d ends;
  bool joint = false;
  LineFrame frame;
  std::array<double, 4> q = {0.0, 0.0, 0.0, 0.0};
  double world_weight = 0.0;
};

std::vector<LineModel> makeLineModels(const CorrespondenceSet& data, const RefinementOptions& options,
                                      const NoiseLevels& noise)
{
  std::vector<LineModel> models(data.lines.size());
  for (size_t i = 0; i < data.lines.size(); ++i)
  {
    const auto& line = data.lines[i];
    LineModel& m = models[i];
    if (line.world.empty())
      continue;
    m.ends = options.line_residual == LineResidual::kJoint ? fitWorldLine(line.world)
                                                           : FittedLine3d{line.world.front(), line.world.back()};
    const double sigma = line.world_point_sigma_m >= 0.0 ? line.world_point_sigma_m : noise.world_sigma_m;
    const Eigen::Vector3d direction = m.ends.b - m.ends.a;
    if (options.line_residual != LineResidual::kJoint || line.world.size() < 2 || !(sigma > 0.0) ||
        !(direction.norm() > 0.0))
      continue;
    m.joint = true;
    m.frame.a0 = m.ends.a;
    m.frame.b0 = m.ends.b;
    const Eigen::Vector3d u = direction.normalized();
    m.frame.e1 = u.unitOrthogonal();
    m.frame.e2 = u.cross(m.frame.e1);
    m.world_weight = noise.image_sigma_px / sigma;
  }
  return models;
}

// A plumb line: an image point, undistorted about the principal point, to the straight line (normal angle theta,
// offset rho, undistorted px about the principal point) that its polyline must be; scaled back by the local scale.
struct StraightLineResidual
{
  double r_ref2;
  Eigen::Vector2d image;

  template <typename T>
  bool operator()(const T* principal, const T* distortion, const T* line, T* residual) const
  {
    const T dx = T(image.x()) - principal[0];
    const T dy = T(image.y()) - principal[1];
    const T scale = T(1.0) + distortion[0] / T(r_ref2) * (dx * dx + dy * dy);
    if (!(scale > T(0.0)))
      return false;
    residual[0] = (cos(line[0]) * dx / scale + sin(line[0]) * dy / scale - line[1]) * scale;
    return true;
  }
};

struct PointResidual
{
  Projector projector;
  Eigen::Vector3d world;
  Eigen::Vector2d image;

  template <typename T>
  bool operator()(const T* focal, const T* principal, const T* skew, const T* distortion, const T* delta,
                  const T* center, T* residual) const
  {
    T m[2];
    if (!projector(focal, principal, skew, distortion, delta, center, world, m))
      return false;
    residual[0] = m[0] - T(image.x());
    residual[1] = m[1] - T(image.y());
    return true;
  }
};

// (fx - fy) / mean(fx, fy), weighted.
struct AspectPrior
{
  double weight;
  template <typename T>
  bool operator()(const T* focal, T* residual) const
  {
    residual[0] = T(weight) * (focal[0] - focal[1]) / (T(0.5) * (focal[0] + focal[1]));
    return true;
  }
};

// Principal point minus the image centre, weighted.
struct PrincipalPointPrior
{
  Eigen::Vector2d center;
  double weight;
  template <typename T>
  bool operator()(const T* principal, T* residual) const
  {
    residual[0] = T(weight) * (principal[0] - T(center.x()));
    residual[1] = T(weight) * (principal[1] - T(center.y()));
    return true;
  }
};

CameraModel toCamera(const Parameters& p, const Projector& projector)
{
  Intrinsics in;
  in.fx = p.focal[0];
  in.fy = projector.single_focal ? p.focal[0] : p.focal[1];
  in.cx = p.principal[0];
  in.cy = p.principal[1];
  in.skew = p.skew[0];
  DivisionModel distortion{p.distortion[0] / projector.r_ref2, in.principalPoint()};
  Eigen::Matrix3d delta;
  ceres::AngleAxisToRotationMatrix(p.delta, ceres::ColumnMajorAdapter3x3(delta.data()));
  CameraPose pose;
  pose.rotation = delta * projector.r0;
  const Eigen::Vector3d c(p.center[0], p.center[1], p.center[2]);
  pose.translation = -pose.rotation * c;
  return CameraModel(in, distortion, pose);
}

// The part of the polyline nearest to a pixel (first and last parts extended), as in distanceToPolyline.
size_t nearestPart(const Eigen::Vector2d& m, const std::vector<Eigen::Vector2d>& polyline)
{
  size_t best = 0;
  double best_distance = std::numeric_limits<double>::infinity();
  const size_t parts = polyline.size() - 1;
  for (size_t j = 0; j < parts; ++j)
  {
    const double d = distanceToPolyline(m, {polyline[j], polyline[j + 1]});
    // distanceToPolyline of a single part is the infinite line's distance; prefer parts whose extent covers m.
    const Eigen::Vector2d ab = polyline[j + 1] - polyline[j];
    const double t = (m - polyline[j]).dot(ab) / ab.squaredNorm();
    const double outside = (j == 0           ? std::max(0.0, t - 1.0)
                            : j + 1 == parts ? std::max(0.0, -t)
                                             : std::max({0.0, -t, t - 1.0})) *
                           ab.norm();
    const double score = d + outside;
    if (score < best_distance)
    {
      best_distance = score;
      best = j;
    }
  }
  return best;
}

std::unique_ptr<ceres::LossFunction> makeLoss(RobustLoss loss, double scale)
{
  switch (loss)
  {
    case RobustLoss::kHuber:
      return std::make_unique<ceres::HuberLoss>(scale);
    case RobustLoss::kCauchy:
      return std::make_unique<ceres::CauchyLoss>(scale);
    case RobustLoss::kNone:
      break;
  }
  return nullptr;
}

double rmsOf(const std::vector<double>& residuals)
{
  double sum = 0.0;
  for (double r : residuals)
    sum += r * r;
  return residuals.empty() ? 0.0 : std::sqrt(sum / residuals.size());
}
}  // namespace

std::optional<RobustLoss> parseRobustLoss(const std::string& name)
{
  if (name == "none")
    return RobustLoss::kNone;
  if (name == "huber")
    return RobustLoss::kHuber;
  if (name == "cauchy")
    return RobustLoss::kCauchy;
  return std::nullopt;
}

std::optional<LineResidual> parseLineResidual(const std::string& name)
{
  if (name == "image")
    return LineResidual::kImagePoints;
  if (name == "world")
    return LineResidual::kWorldPoints;
  if (name == "both")
    return LineResidual::kBoth;
  if (name == "joint")
    return LineResidual::kJoint;
  return std::nullopt;
}

const char* toString(RobustLoss loss)
{
  switch (loss)
  {
    case RobustLoss::kNone:
      return "none";
    case RobustLoss::kHuber:
      return "huber";
    case RobustLoss::kCauchy:
      return "cauchy";
  }
  return "?";
}

void quietSolverLogging()
{
  FLAGS_minloglevel = google::GLOG_FATAL;
  FLAGS_logtostderr = true;
}

Expected<RefinementResult> refineCamera(const CorrespondenceSet& data, const CameraModel& initial,
                                        const RefinementOptions& options, const std::vector<bool>& use_line)
{
  if (const Status valid = data.validate(); !valid)
    return valid.error();
  if (!use_line.empty() && use_line.size() != data.lines.size())
    return Error(ErrorCode::kInvalidInput, "use_line has " + std::to_string(use_line.size()) + " entries for " +
                                               std::to_string(data.lines.size()) + " lines");
  const auto selected = [&](size_t i) { return use_line.empty() || use_line[i]; };

  Projector projector;
  projector.r0 = initial.pose().rotation;
  projector.single_focal = options.single_focal;
  const double half_diagonal = 0.5 * std::hypot(data.image_width, data.image_height);
  projector.r_ref2 = half_diagonal * half_diagonal;

  Parameters p;
  const Intrinsics& in = initial.intrinsics();
  p.focal[0] = options.single_focal ? 0.5 * (in.fx + in.fy) : in.fx;
  p.focal[1] = in.fy;
  p.principal[0] = in.cx;
  p.principal[1] = in.cy;
  p.skew[0] = options.estimate_skew ? in.skew : 0.0;
  p.distortion[0] = options.estimate_distortion ? initial.distortion().lambda * projector.r_ref2 : 0.0;
  const Eigen::Vector3d c0 = initial.pose().center();
  for (int i = 0; i < 3; ++i)
    p.center[i] = c0(i);

  RefinementResult result;
  {
    // The starting error, with the pairing of points and parts the initial camera gives.
    std::vector<double> r;
    for (size_t i = 0; i < data.lines.size(); ++i)
      if (selected(i))
        for (double d : lineResiduals(toCamera(p, projector), data.lines[i]))
          r.push_back(d);
    result.initial_rms_px = rmsOf(r);
    result.loss_scale_px = options.loss_scale_px;
    if (!(result.loss_scale_px > 0.0))
    {
      const double median = summarize(r).median_px;
      result.loss_scale_px = std::max(0.5, 2.5 * median / 0.6745);
    }
  }

  // Lines whose 3D position is uncertain (LineCorrespondence::world_sigma_m) count less: the error of a 3D line moves
  // all its n residuals together, so each residual gets the weight sqrt(s0^2 / (s0^2 + n s^2)), s the 3D sigma seen
  // from the initial camera in px (f sigma / depth) and s0 the image noise (an option, not an estimate: the weights
  // must not depend on the start, whose optima are compared).
  std::vector<double> line_weight(data.lines.size(), 1.0);
  if (options.weight_by_world_sigma && options.line_residual != LineResidual::kJoint)
  {
    const CameraModel current = toCamera(p, projector);
    const double s0 = options.world_sigma_image_noise_px;
    for (size_t i = 0; i < data.lines.size(); ++i)
    {
      const auto& line = data.lines[i];
      if (!(line.world_sigma_m > 0.0) || line.world.empty())
        continue;
      const Eigen::Vector3d mid = 0.5 * (line.world.front() + line.world.back());
      const double depth = (current.pose().rotation * mid + current.pose().translation).z();
      if (!(depth > 0.0))
        continue;
      const double s = current.intrinsics().fx * line.world_sigma_m / depth;
      const double n = static_cast<double>(options.line_residual == LineResidual::kWorldPoints ? line.world.size()
                                                                                               : line.image.size());
      line_weight[i] = std::sqrt(s0 * s0 / (s0 * s0 + n * s * s));
    }
  }

  // kJoint: the noise levels (given or estimated with the initial distortion) and each line's 3D line.
  NoiseLevels noise;
  if (options.line_residual == LineResidual::kJoint)
  {
    noise = estimateNoiseLevels(data, initial.distortion(), options.image_sigma_px, options.world_sigma_m);
    result.image_sigma_px = noise.image_sigma_px;
    result.world_sigma_m = noise.world_sigma_m;
  }
  std::vector<LineModel> models = makeLineModels(data, options, noise);
  const bool image_residuals = options.line_residual != LineResidual::kWorldPoints;
  const bool only_image_residuals =
      options.line_residual == LineResidual::kImagePoints || options.line_residual == LineResidual::kJoint;

  // Plumb lines: each gets its straight line (theta, rho), fitted to its points undistorted with the initial camera.
  std::vector<std::array<double, 2>> straight(options.use_straight_lines ? data.straight_lines.size() : 0);
  for (size_t k = 0; k < straight.size(); ++k)
  {
    const auto& polyline = data.straight_lines[k];
    const DivisionModel d{p.distortion[0] / projector.r_ref2, Eigen::Vector2d(p.principal[0], p.principal[1])};
    std::vector<Eigen::Vector2d> u;
    for (const auto& m : polyline)
    {
      const Eigen::Vector2d rel = m - d.center;
      u.push_back(rel / (1.0 + d.lambda * rel.squaredNorm()));
    }
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& x : u)
      mean += x / static_cast<double>(u.size());
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& x : u)
      cov += (x - mean) * (x - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    const Eigen::Vector2d normal = eig.eigenvectors().col(0);
    straight[k] = {std::atan2(normal.y(), normal.x()), normal.dot(mean)};
  }
  // Polylines that are not straight under the initial camera (a curved edge, two edges merged) are left out.
  std::vector<bool> straight_used(straight.size(), true);
  for (size_t k = 0; k < straight.size(); ++k)
  {
    const auto& polyline = data.straight_lines[k];
    if (polyline.size() < 3)
      straight_used[k] = false;
    for (const auto& m : polyline)
    {
      const StraightLineResidual f{projector.r_ref2, m};
      double r = 0.0;
      if (!f(p.principal, p.distortion, straight[k].data(), &r) || std::abs(r) > options.max_straight_line_px)
        straight_used[k] = false;
    }
  }

  std::vector<std::vector<size_t>> assignment(data.lines.size());
  ceres::Solver::Summary summary;
  size_t residual_count = 0;
  // The group of every residual row, in the order the blocks are added: the line index, or lines + k for point k.
  std::vector<size_t> row_group;
  std::unique_ptr<ceres::Problem> problem;
  // Image points left out as outliers (a polyline that runs past the end of its edge onto the next one).
  std::vector<std::vector<bool>> vertex_used(data.lines.size());
  for (size_t i = 0; i < data.lines.size(); ++i)
    vertex_used[i].assign(data.lines[i].image.size(), true);
  bool vertices_changed = false;
  for (int round = 0; round <= options.max_reassignments; ++round)
  {
    // Pair each world point with its nearest part under the current camera.
    const CameraModel current = toCamera(p, projector);
    bool changed = false;
    for (size_t i = 0; i < data.lines.size(); ++i)
    {
      if (!selected(i))
        continue;
      const auto& line = data.lines[i];
      std::vector<size_t> parts(line.world.size(), 0);
      for (size_t k = 0; k < line.world.size(); ++k)
      {
        const auto m = current.project(line.world[k]);
        parts[k] = m ? nearestPart(*m, line.image) : 0;
      }
      changed = changed || parts != assignment[i];
      assignment[i] = parts;
    }
    // The pairing only matters for world-point residuals: with image-point residuals one solve is enough.
    if (round > 0 && !vertices_changed && (!changed || only_image_residuals))
      break;

    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
    problem = std::make_unique<ceres::Problem>(problem_options);
    residual_count = 0;
    row_group.clear();
    for (size_t i = 0; i < data.lines.size(); ++i)
    {
      if (!selected(i))
        continue;
      const auto& line = data.lines[i];
      LineModel& model = models[i];
      if (image_residuals && line.world.size() >= 2 && (model.ends.b - model.ends.a).norm() > 0.0)
      {
        for (size_t v = 0; v < line.image.size(); ++v)
        {
          if (!vertex_used[i][v])
            continue;
          if (model.joint)
            problem->AddResidualBlock(new ceres::AutoDiffCostFunction<JointImageResidual, 1, 2, 2, 1, 1, 3, 3, 4>(
                                          new JointImageResidual{projector, model.frame, line.image[v]}),
                                      makeLoss(options.loss, result.loss_scale_px).release(), p.focal, p.principal,
                                      p.skew, p.distortion, p.delta, p.center, model.q.data());
          else
            problem->AddResidualBlock(
                new ceres::AutoDiffCostFunction<ImagePointToLineResidual, 1, 2, 2, 1, 1, 3, 3>(
                    new ImagePointToLineResidual{projector, model.ends.a, model.ends.b, line.image[v], line_weight[i]}),
                makeLoss(options.loss, result.loss_scale_px).release(), p.focal, p.principal, p.skew, p.distortion,
                p.delta, p.center);
          ++residual_count;
          row_group.push_back(i);
        }
        for (size_t k = 0; model.joint && k < line.world.size(); ++k)
        {
          problem->AddResidualBlock(new ceres::AutoDiffCostFunction<WorldPointToLineResidual, 2, 4>(
                                        new WorldPointToLineResidual{model.frame, line.world[k], model.world_weight}),
                                    makeLoss(options.loss, result.loss_scale_px).release(), model.q.data());
          residual_count += 2;
          row_group.push_back(i);
          row_group.push_back(i);
        }
        if (only_image_residuals)
          continue;
      }
      for (size_t k = 0; k < line.world.size(); ++k)
      {
        const Eigen::Vector2d a = line.image[assignment[i][k]];
        const Eigen::Vector2d b = line.image[assignment[i][k] + 1];
        const Eigen::Vector2d dir = (b - a).normalized();
        auto* cost = new ceres::AutoDiffCostFunction<PointToPartResidual, 1, 2, 2, 1, 1, 3, 3>(
            new PointToPartResidual{projector, line.world[k], a, Eigen::Vector2d(-dir.y(), dir.x()), line_weight[i]});
        problem->AddResidualBlock(cost, makeLoss(options.loss, result.loss_scale_px).release(), p.focal, p.principal,
                                  p.skew, p.distortion, p.delta, p.center);
        ++residual_count;
        row_group.push_back(i);
      }
    }
    for (size_t k = 0; k < data.points.size(); ++k)
    {
      const auto& point = data.points[k];
      auto* cost = new ceres::AutoDiffCostFunction<PointResidual, 2, 2, 2, 1, 1, 3, 3>(
          new PointResidual{projector, point.world, point.image});
      problem->AddResidualBlock(cost, makeLoss(options.loss, result.loss_scale_px).release(), p.focal, p.principal,
                                p.skew, p.distortion, p.delta, p.center);
      residual_count += 2;
      row_group.push_back(data.lines.size() + k);
      row_group.push_back(data.lines.size() + k);
    }
    for (size_t k = 0; k < straight.size(); ++k)
      for (const auto& m : straight_used[k] ? data.straight_lines[k] : std::vector<Eigen::Vector2d>{})
      {
        problem->AddResidualBlock(new ceres::AutoDiffCostFunction<StraightLineResidual, 1, 2, 1, 2>(
                                      new StraightLineResidual{projector.r_ref2, m}),
                                  makeLoss(options.loss, result.loss_scale_px).release(), p.principal, p.distortion,
                                  straight[k].data());
        ++residual_count;
        row_group.push_back(data.lines.size() + data.points.size() + k);
      }
    if (residual_count == 0)
      return Error(ErrorCode::kNotEnoughData, "refinement has no residuals (no selected line or point)");
    // Weak priors, in the residuals' units (scaled by the noise level estimated before the solve, so that the
    // covariance, which is scaled by the residual variance afterwards, sees them with their own sigma).
    const double noise = std::max(0.05, result.loss_scale_px / 2.5);
    if (!options.single_focal && options.aspect_prior_sigma > 0.0)
    {
      problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<AspectPrior, 1, 2>(new AspectPrior{noise / options.aspect_prior_sigma}),
          nullptr, p.focal);
      row_group.push_back(std::numeric_limits<size_t>::max());
    }
    if (options.estimate_principal_point && options.principal_point_prior_sigma > 0.0)
    {
      problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<PrincipalPointPrior, 2, 2>(new PrincipalPointPrior{
              data.imageCenter(), noise / (options.principal_point_prior_sigma * data.image_width)}),
          nullptr, p.principal);
      row_group.push_back(std::numeric_limits<size_t>::max());
      row_group.push_back(std::numeric_limits<size_t>::max());
    }
    if (options.single_focal)
      problem->SetManifold(p.focal, new ceres::SubsetManifold(2, {1}));
    if (!options.estimate_skew)
      problem->SetParameterBlockConstant(p.skew);
    if (!options.estimate_distortion)
      problem->SetParameterBlockConstant(p.distortion);
    if (!options.estimate_principal_point)
      problem->SetParameterBlockConstant(p.principal);

    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_QR;
    solver_options.max_num_iterations = options.max_iterations;
    solver_options.function_tolerance = 1e-12;
    solver_options.gradient_tolerance = 1e-12;
    solver_options.parameter_tolerance = 1e-12;
    solver_options.num_threads = 1;
    ceres::Solve(solver_options, problem.get(), &summary);
    result.iterations += static_cast<int>(summary.iterations.size());
    if (summary.termination_type == ceres::FAILURE)
      return Error(ErrorCode::kNoSolution, "refinement failed: " + summary.message);

    // Image points far beyond the noise level of all image points are left out and the solve repeated; a line keeps
    // at least two.
    vertices_changed = false;
    if (options.vertex_outlier_sigmas > 0.0 && options.line_residual != LineResidual::kWorldPoints)
    {
      std::vector<std::vector<double>> distance(data.lines.size());
      std::vector<double> all;
      for (size_t i = 0; i < data.lines.size(); ++i)
      {
        const auto& line = data.lines[i];
        if (!selected(i) || line.world.size() < 2 || !((models[i].ends.b - models[i].ends.a).norm() > 0.0))
          continue;
        Eigen::Vector3d a = models[i].ends.a, b = models[i].ends.b;
        if (models[i].joint)
          models[i].frame.ends(models[i].q.data(), a.data(), b.data());
        const ImagePointToLineResidual functor{projector, a, b, Eigen::Vector2d()};
        for (const auto& m : line.image)
        {
          ImagePointToLineResidual f = functor;
          f.image = m;
          double r = std::numeric_limits<double>::infinity();
          f(p.focal, p.principal, p.skew, p.distortion, p.delta, p.center, &r);
          distance[i].push_back(std::abs(r));
        }
        for (size_t v = 0; v < distance[i].size(); ++v)
          if (vertex_used[i][v] && std::isfinite(distance[i][v]))
            all.push_back(distance[i][v]);
      }
      if (!all.empty())
      {
        std::nth_element(all.begin(), all.begin() + all.size() / 2, all.end());
        const double threshold =
            std::max(options.min_vertex_outlier_px, options.vertex_outlier_sigmas * 1.4826 * all[all.size() / 2]);
        for (size_t i = 0; i < data.lines.size(); ++i)
        {
          if (distance[i].empty())
            continue;
          std::vector<bool> used(distance[i].size());
          for (size_t v = 0; v < used.size(); ++v)
            used[v] = distance[i][v] <= threshold;
          if (std::count(used.begin(), used.end(), true) < 2)
            used.assign(used.size(), true);
          if (used != vertex_used[i])
          {
            vertex_used[i] = used;
            vertices_changed = true;
          }
        }
      }
    }
  }

  result.camera = toCamera(p, projector);
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.termination = summary.message;
  result.residuals = residual_count;
  {
    std::vector<double> r;
    for (size_t i = 0; i < data.lines.size(); ++i)
      if (selected(i))
        for (double d : lineResiduals(result.camera, data.lines[i]))
          r.push_back(d);
    result.final_rms_px = rmsOf(r);
  }

  // The Jacobian at the optimum (free parameters only, plain residuals), for the per-line diagnostics and the
  // jackknife over lines.
  std::vector<double*> free_blocks = {p.focal};
  std::vector<int> block_size = {options.single_focal ? 1 : 2};
  if (options.estimate_principal_point)
  {
    free_blocks.push_back(p.principal);
    block_size.push_back(2);
  }
  if (options.estimate_skew)
  {
    free_blocks.push_back(p.skew);
    block_size.push_back(1);
  }
  if (options.estimate_distortion)
  {
    free_blocks.push_back(p.distortion);
    block_size.push_back(1);
  }
  free_blocks.push_back(p.delta);
  block_size.push_back(3);
  free_blocks.push_back(p.center);
  block_size.push_back(3);
  // The plumb lines' own parameters are nuisance parameters: in the normal equations (so that the camera's
  // uncertainty accounts for them), not in the reported covariance.
  for (size_t k = 0; k < straight.size(); ++k)
    if (straight_used[k])
    {
      free_blocks.push_back(straight[k].data());
      block_size.push_back(2);
    }
  const int columns = std::accumulate(block_size.begin(), block_size.end(), 0);
  const auto column_of = [&](const double* block) {
    int c = 0;
    for (size_t b = 0; b < free_blocks.size(); ++b)
    {
      if (free_blocks[b] == block)
        return c;
      c += block_size[b];
    }
    return -1;
  };
  const size_t groups = data.lines.size() + data.points.size() + straight.size();
  result.line_rms_px.assign(data.lines.size(), std::numeric_limits<double>::quiet_NaN());
  result.line_loo_rms_px.assign(data.lines.size(), std::numeric_limits<double>::quiet_NaN());
  result.line_influence.assign(data.lines.size(), std::numeric_limits<double>::quiet_NaN());
  Eigen::MatrixXd jackknife;  // covariance of the parameters from leaving out one line (or point) at a time
  double reciprocal_condition = 0.0;
  {
    ceres::Problem::EvaluateOptions evaluate_options;
    evaluate_options.apply_loss_function = false;
    evaluate_options.parameter_blocks = free_blocks;
    std::vector<double> residuals;
    ceres::CRSMatrix crs;
    if (problem->Evaluate(evaluate_options, nullptr, &residuals, nullptr, &crs) &&
        residuals.size() == row_group.size() && crs.num_cols == columns)
    {
      const int rows = crs.num_rows;
      Eigen::MatrixXd j = Eigen::MatrixXd::Zero(rows, columns);
      for (int r = 0; r < rows; ++r)
        for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k)
          j(r, crs.cols[k]) = crs.values[k];
      const Eigen::Map<const Eigen::VectorXd> res(residuals.data(), rows);
      // Column scaling, then a pseudo-inverse of the normal matrix (directions the data do not constrain get none).
      Eigen::VectorXd scale(columns);
      for (int c = 0; c < columns; ++c)
      {
        const double n = j.col(c).norm();
        scale(c) = n > 0.0 ? 1.0 / n : 0.0;
      }
      const Eigen::MatrixXd js = j * scale.asDiagonal();
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(js.transpose() * js);
      const Eigen::VectorXd values = eig.eigenvalues();
      const double largest = values.maxCoeff();
      reciprocal_condition = largest > 0.0 ? std::max(0.0, values.minCoeff()) / largest : 0.0;
      Eigen::VectorXd inverse_values = Eigen::VectorXd::Zero(columns);
      for (int c = 0; c < columns; ++c)
        if (values(c) > 1e-12 * largest)
          inverse_values(c) = 1.0 / values(c);
      const Eigen::MatrixXd h_inverse = scale.asDiagonal() * eig.eigenvectors() * inverse_values.asDiagonal() *
                                        eig.eigenvectors().transpose() * scale.asDiagonal();
      std::vector<std::vector<int>> rows_of(groups);
      for (int r = 0; r < rows; ++r)
        if (row_group[r] < groups)
          rows_of[row_group[r]].push_back(r);
      jackknife = Eigen::MatrixXd::Zero(columns, columns);
      size_t used_groups = 0;
      const double variance = rows > columns ? res.squaredNorm() / (rows - columns) : 0.0;
      for (size_t g = 0; g < groups; ++g)
      {
        const std::vector<int>& own = rows_of[g];
        if (own.empty())
          continue;
        ++used_groups;
        Eigen::MatrixXd jg(own.size(), columns);
        Eigen::VectorXd rg(own.size());
        for (size_t k = 0; k < own.size(); ++k)
        {
          jg.row(k) = j.row(own[k]);
          rg(k) = res(own[k]);
        }
        // Linearised leave-one-out: r_(-g) = (I - J_g H^-1 J_g^T)^-1 r_g, and the parameters move by
        // H^-1 J_g^T r_(-g) when the group is left out.
        const Eigen::MatrixXd m = Eigen::MatrixXd::Identity(own.size(), own.size()) - jg * h_inverse * jg.transpose();
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> meig(m);
        const double smallest = meig.eigenvalues().minCoeff();
        double loo_rms = std::numeric_limits<double>::infinity();
        double influence = std::numeric_limits<double>::infinity();
        if (smallest > 1e-6)
        {
          const Eigen::VectorXd loo = meig.eigenvectors() * (meig.eigenvalues().cwiseInverse().asDiagonal() *
                                                             (meig.eigenvectors().transpose() * rg));
          loo_rms = std::sqrt(loo.squaredNorm() / own.size());
          const Eigen::VectorXd shift = h_inverse * jg.transpose() * loo;
          jackknife += shift * shift.transpose();
          influence = variance > 0.0 ? (j * shift).squaredNorm() / (columns * variance) : 0.0;
        }
        if (g < data.lines.size())
        {
          result.line_rms_px[g] = std::sqrt(rg.squaredNorm() / own.size());
          result.line_loo_rms_px[g] = loo_rms;
          result.line_influence[g] = influence;
        }
      }
      if (used_groups > 1)
        jackknife *= static_cast<double>(used_groups - 1) / used_groups;
    }
  }

  if (options.compute_uncertainty)
  {
    CameraUncertainty& u = result.uncertainty;
    u.reciprocal_condition = reciprocal_condition;
    size_t joint_lines = 0;
    for (size_t i = 0; i < data.lines.size(); ++i)
      joint_lines += selected(i) && models[i].joint ? 1 : 0;
    const size_t free_parameters = 4 * joint_lines + 2 * std::count(straight_used.begin(), straight_used.end(), true) +
                                   (options.single_focal ? 1 : 2) + (options.estimate_principal_point ? 2 : 0) +
                                   (options.estimate_skew ? 1 : 0) + (options.estimate_distortion ? 1 : 0) + 6;
    if (residual_count <= free_parameters)
    {
      u.reason = "as many parameters as residuals: no redundancy to estimate uncertainty from";
    }
    else
    {
      ceres::Covariance::Options covariance_options;
      covariance_options.algorithm_type = ceres::DENSE_SVD;
      covariance_options.null_space_rank = 0;
      covariance_options.min_reciprocal_condition_number = 1e-14;
      ceres::Covariance covariance(covariance_options);
      std::vector<std::pair<const double*, const double*>> blocks = {{p.focal, p.focal},
                                                                     {p.principal, p.principal},
                                                                     {p.distortion, p.distortion},
                                                                     {p.delta, p.delta},
                                                                     {p.center, p.center}};
      if (!covariance.Compute(blocks, problem.get()))
      {
        u.reason =
            "rank deficient: the data leave the camera under-constrained (for example all lines in one "
            "plane or too few directions); no uncertainty can be given";
      }
      else
      {
        // Ceres assumes unit-variance residuals: scale by the residual variance, from the plain squared residuals
        // (the robust loss's cost would understate it) over the degrees of freedom.
        ceres::Problem::EvaluateOptions evaluate_options;
        evaluate_options.apply_loss_function = false;
        double plain_cost = 0.0;
        problem->Evaluate(evaluate_options, &plain_cost, nullptr, nullptr, nullptr);
        const double sigma2 = 2.0 * plain_cost / static_cast<double>(residual_count - free_parameters);
        u.residual_sigma_px = std::sqrt(sigma2);
        double focal[4], principal[4], distortion[1], delta[9], center[9];
        covariance.GetCovarianceBlock(p.focal, p.focal, focal);
        covariance.GetCovarianceBlock(p.principal, p.principal, principal);
        covariance.GetCovarianceBlock(p.distortion, p.distortion, distortion);
        covariance.GetCovarianceBlock(p.delta, p.delta, delta);
        covariance.GetCovarianceBlock(p.center, p.center, center);
        u.available = true;
        u.fx = std::sqrt(sigma2 * focal[0]);
        u.fy = options.single_focal ? u.fx : std::sqrt(sigma2 * focal[3]);
        u.cx = std::sqrt(sigma2 * principal[0]);
        u.cy = std::sqrt(sigma2 * principal[3]);
        u.lambda = std::sqrt(sigma2 * distortion[0]) / projector.r_ref2;
        u.rotation_deg = std::sqrt(sigma2 * (delta[0] + delta[4] + delta[8])) * 180.0 / M_PI;
        u.position_m = std::sqrt(sigma2 * (center[0] + center[4] + center[8]));
        if (options.per_line_uncertainty && jackknife.rows() == columns)
        {
          // The larger of the two, per parameter.
          const auto widen = [&](double* sigma, double variance) {
            const double jack = std::sqrt(std::max(0.0, variance));
            if (*sigma > 0.0)
              u.line_correlation_factor = std::max(u.line_correlation_factor, jack / *sigma);
            *sigma = std::max(*sigma, jack);
          };
          const int f = column_of(p.focal), c = column_of(p.principal), d = column_of(p.delta), x = column_of(p.center),
                    k = column_of(p.distortion);
          widen(&u.fx, jackknife(f, f));
          if (options.single_focal)
            u.fy = u.fx;
          else
            widen(&u.fy, jackknife(f + 1, f + 1));
          if (c >= 0)
          {
            widen(&u.cx, jackknife(c, c));
            widen(&u.cy, jackknife(c + 1, c + 1));
          }
          if (k >= 0)
            widen(&u.lambda, jackknife(k, k) / (projector.r_ref2 * projector.r_ref2));
          widen(&u.rotation_deg, jackknife.block(d, d, 3, 3).trace() * std::pow(180.0 / M_PI, 2));
          widen(&u.position_m, jackknife.block(x, x, 3, 3).trace());
        }
      }
    }
  }
  return result;
}

}  // namespace insitu_calibration
