#include "insitu_calibration/refine/refinement.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numeric>

#include <Eigen/Dense>

#include <ceres/ceres.h>
#include <glog/logging.h>
#include <Eigen/Geometry>

#include "insitu_calibration/metrics.h"
#include "insitu_calibration/robust_statistics.h"
#include "insitu_calibration/refine/noise_model.h"
#include "refine/cost_functions.h"
#include "refine/refinement_uncertainty.h"

namespace insitu_calibration
{
namespace
{
using namespace refinement;

// The priors' noise level: at least this (px), so that on a near-exact fit they keep a weight (the direction they
// hold stays determined); re-solved while it differs from the fit's by more than the tolerance, at most this many
// times.
constexpr double kMinPriorNoisePx = 0.01;
constexpr double kPriorNoiseTolerance = 0.2;
constexpr int kMaxPriorNoisePasses = 3;

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

Projector makeProjector(const CorrespondenceSet& data, const CameraModel& initial, const RefinementOptions& options)
{
  Projector projector;
  projector.r0 = initial.pose().rotation;
  projector.single_focal = options.single_focal;
  const double half_diagonal = 0.5 * std::hypot(data.image_width, data.image_height);
  projector.r_ref2 = half_diagonal * half_diagonal;
  return projector;
}

Parameters initialParameters(const CameraModel& initial, const RefinementOptions& options, const Projector& projector)
{
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
  return p;
}

// Plumb lines: each polyline's straight line (theta, rho) and whether it takes part.
struct StraightLines
{
  std::vector<std::array<double, 2>> params;
  std::vector<bool> used;
};

// Direction lines: each one's angle phi about its direction (DirectionLineResidual), its frame across the direction
// and whether it takes part.
struct DirectionLines
{
  std::vector<std::array<double, 1>> phi;
  std::vector<std::array<Eigen::Vector3d, 3>> frames;  // direction, e1, e2
  std::vector<bool> used;
  std::vector<double> weight;  // DirectionLineResidual::weight (reweighDirectionLines)
  // Per azimuth group (DirectionLine::azimuth_group) its correction, free when a used line has it; and the constant
  // zero of exact directions.
  std::map<int, std::array<double, 1>> azimuth;
  std::array<double, 1> exact = {0.0};

  double* azimuthOf(int group) { return group < 0 ? exact.data() : azimuth.at(group).data(); }
  const double* azimuthOf(int group) const { return group < 0 ? exact.data() : azimuth.at(group).data(); }
  std::vector<int> usedAzimuthGroups(const CorrespondenceSet& data) const
  {
    std::vector<int> out;
    for (const auto& [group, value] : azimuth)
      for (size_t k = 0; k < used.size(); ++k)
        if (used[k] && data.direction_lines[k].azimuth_group == group)
        {
          out.push_back(group);
          break;
        }
    return out;
  }
};

// Everything one refinement works on: the data, the parameters solved for and the per-line state that the rounds of
// pairing and outlier rejection update.
struct RefinementState
{
  const CorrespondenceSet& data;
  const RefinementOptions& options;
  const std::vector<bool>& use_line;
  Projector projector;
  Parameters p;
  double loss_scale_px = 0.0;
  // The residuals' noise level (px) the priors are scaled by: first guessed from the initial camera's residuals,
  // then the fit's own (refineCamera).
  double prior_noise_px = 0.0;
  std::vector<double> line_weight;
  std::vector<LineModel> models;
  StraightLines straight;
  DirectionLines direction;
  std::vector<std::vector<size_t>> assignment;  // per line and world point: its nearest image part
  std::vector<std::vector<bool>> vertex_used;   // per line and image point: false once left out as an outlier

  RefinementState(const CorrespondenceSet& data, const RefinementOptions& options, const std::vector<bool>& use_line,
                  const CameraModel& initial)
      : data(data),
        options(options),
        use_line(use_line),
        projector(makeProjector(data, initial, options)),
        p(initialParameters(initial, options, projector))
  {}

  bool selected(size_t i) const { return use_line.empty() || use_line[i]; }
  CameraModel camera() const { return toCamera(p, projector); }
  // Image-point residuals need a 3D line of two distinct points.
  bool hasLine(size_t i) const
  {
    return data.lines[i].world.size() >= 2 && (models[i].ends.b - models[i].ends.a).norm() > 0.0;
  }
};

// The Ceres problem of one round and, per residual row, its group: the line index, lines + k for point k,
// lines + points + k for plumb line k, or none (max) for a prior.
struct BuiltProblem
{
  std::unique_ptr<ceres::Problem> problem;
  size_t residual_count = 0;
  std::vector<size_t> row_group;
};

// The selected lines' residuals under `camera`, each world point paired with its nearest image part.
std::vector<double> selectedLineResiduals(const RefinementState& s, const CameraModel& camera)
{
  std::vector<double> r;
  for (size_t i = 0; i < s.data.lines.size(); ++i)
    if (s.selected(i))
      for (double d : lineResiduals(camera, s.data.lines[i]))
        r.push_back(d);
  return r;
}

// Lines whose 3D position is uncertain (LineCorrespondence::world_sigma_m) count less: the error of a 3D line moves
// all its n residuals together, so each residual gets the weight sqrt(s0^2 / (s0^2 + n s^2)), s the 3D sigma seen
// from the initial camera in px (f sigma / depth) and s0 the image noise (an option, not an estimate: the weights
// must not depend on the start, whose optima are compared).
std::vector<double> worldSigmaWeights(const RefinementState& s)
{
  std::vector<double> weight(s.data.lines.size(), 1.0);
  if (!s.options.weight_by_world_sigma || s.options.line_residual == LineResidual::kJoint)
    return weight;
  const CameraModel current = s.camera();
  const double s0 = s.options.world_sigma_image_noise_px;
  for (size_t i = 0; i < s.data.lines.size(); ++i)
  {
    const auto& line = s.data.lines[i];
    if (!(line.world_sigma_m > 0.0) || line.world.empty())
      continue;
    const Eigen::Vector3d mid = 0.5 * (line.world.front() + line.world.back());
    const double depth = (current.pose().rotation * mid + current.pose().translation).z();
    if (!(depth > 0.0))
      continue;
    const double sigma_px = current.intrinsics().fx * line.world_sigma_m / depth;
    const double n = static_cast<double>(s.options.line_residual == LineResidual::kWorldPoints ? line.world.size()
                                                                                               : line.image.size());
    weight[i] = std::sqrt(s0 * s0 / (s0 * s0 + n * sigma_px * sigma_px));
  }
  return weight;
}

// The straight line (theta, rho) through a polyline's points undistorted with the initial camera.
std::array<double, 2> fitStraightLine(const std::vector<Eigen::Vector2d>& polyline, const Parameters& p, double r_ref2)
{
  const DivisionModel d{p.distortion[0] / r_ref2, Eigen::Vector2d(p.principal[0], p.principal[1])};
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
  return {std::atan2(normal.y(), normal.x()), normal.dot(mean)};
}

// Polylines that are not straight under the initial camera (a curved edge, two edges merged) are left out.
StraightLines fitStraightLines(const RefinementState& s)
{
  StraightLines out;
  const size_t count = s.options.use_straight_lines ? s.data.straight_lines.size() : 0;
  for (size_t k = 0; k < count; ++k)
    out.params.push_back(fitStraightLine(s.data.straight_lines[k], s.p, s.projector.r_ref2));
  out.used.assign(count, true);
  for (size_t k = 0; k < count; ++k)
  {
    const auto& polyline = s.data.straight_lines[k];
    if (polyline.size() < 3)
      out.used[k] = false;
    for (const auto& m : polyline)
    {
      const StraightLineResidual f{s.projector.r_ref2, m};
      double r = 0.0;
      if (!f(s.p.principal, s.p.distortion, out.params[k].data(), &r) || std::abs(r) > s.options.max_straight_line_px)
        out.used[k] = false;
    }
  }
  return out;
}

// A direction line's weight: its points' own noise `noise_ratio` times the image noise the weights assume
// (world_sigma_image_noise_px, s0; reweighDirectionLines), and its error as a whole (direction_line_sigma_px), as
// worldSigmaWeights weighs a matched line's: s0 / sqrt((ratio s0)^2 + n sigma^2) for n points.
double directionLineWeight(const RefinementOptions& o, size_t points, double noise_ratio)
{
  const double sigma = o.weight_by_world_sigma ? o.direction_line_sigma_px : 0.0;
  const double s0 = o.world_sigma_image_noise_px;
  if (!(sigma > 0.0) || !(s0 > 0.0))
    return 1.0 / noise_ratio;
  return s0 / std::sqrt(noise_ratio * noise_ratio * s0 * s0 + static_cast<double>(points) * sigma * sigma);
}

// Direction lines whose image is not a line through their vanishing point under the initial camera (within
// max_direction_line_px: an edge of another direction, or a wrong start) are left out.
DirectionLines fitDirectionLines(const RefinementState& s)
{
  DirectionLines out;
  const size_t count = s.options.use_direction_lines ? s.data.direction_lines.size() : 0;
  const CameraModel camera = s.camera();
  for (size_t k = 0; k < count; ++k)
  {
    const auto& line = s.data.direction_lines[k];
    const Eigen::Vector3d d = line.direction.normalized();
    const Eigen::Vector3d e1 = d.unitOrthogonal(), e2 = d.cross(e1);
    out.frames.push_back({d, e1, e2});
    if (line.azimuth_group >= 0)
      out.azimuth[line.azimuth_group] = {0.0};
    // phi: the plane through the centre that holds d and the ray of the polyline's middle.
    Eigen::Vector3d ray = Eigen::Vector3d::Zero();
    for (const auto& m : line.image)
      if (const auto r = camera.backProject(m))
        ray += *r;
    const Eigen::Vector3d u = d.cross(camera.pose().rotation.transpose() * ray).cross(d);
    out.phi.push_back({std::atan2(u.dot(e2), u.dot(e1))});
    bool used = line.image.size() >= 2 && u.norm() > 1e-9;
    for (const auto& m : line.image)
    {
      const DirectionLineResidual f{s.projector, d, e1, e2, m};
      double r = 0.0;
      used = used &&
             f(s.p.focal, s.p.principal, s.p.skew, s.p.distortion, s.p.delta, s.p.center, out.phi[k].data(),
               out.exact.data(), &r) &&
             std::abs(r) <= s.options.max_direction_line_px;
    }
    out.used.push_back(used);
    out.weight.push_back(directionLineWeight(s.options, line.image.size(), 1.0));
  }
  return out;
}

// Pairs each world point with its nearest image part under the current camera; true when a pairing changed.
bool pairWorldPointsWithParts(RefinementState& s)
{
  const CameraModel current = s.camera();
  bool changed = false;
  for (size_t i = 0; i < s.data.lines.size(); ++i)
  {
    if (!s.selected(i))
      continue;
    const auto& line = s.data.lines[i];
    std::vector<size_t> parts(line.world.size(), 0);
    for (size_t k = 0; k < line.world.size(); ++k)
    {
      const auto m = current.project(line.world[k]);
      parts[k] = m ? nearestPart(*m, line.image) : 0;
    }
    changed = changed || parts != s.assignment[i];
    s.assignment[i] = parts;
  }
  return changed;
}

// The residuals of line i's image points (kJoint: with its free 3D line and its world points' residuals).
void addImagePointResiduals(RefinementState& s, size_t i, BuiltProblem* built)
{
  const auto& line = s.data.lines[i];
  LineModel& model = s.models[i];
  Parameters& p = s.p;
  for (size_t v = 0; v < line.image.size(); ++v)
  {
    if (!s.vertex_used[i][v])
      continue;
    if (model.joint)
      built->problem->AddResidualBlock(new ceres::AutoDiffCostFunction<JointImageResidual, 1, 2, 2, 1, 1, 3, 3, 4>(
                                           new JointImageResidual{s.projector, model.frame, line.image[v]}),
                                       makeLoss(s.options.loss, s.loss_scale_px).release(), p.focal, p.principal,
                                       p.skew, p.distortion, p.delta, p.center, model.q.data());
    else
      built->problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<ImagePointToLineResidual, 1, 2, 2, 1, 1, 3, 3>(
              new ImagePointToLineResidual{s.projector, model.ends.a, model.ends.b, line.image[v], s.line_weight[i]}),
          makeLoss(s.options.loss, s.loss_scale_px).release(), p.focal, p.principal, p.skew, p.distortion, p.delta,
          p.center);
    ++built->residual_count;
    built->row_group.push_back(i);
  }
  for (size_t k = 0; model.joint && k < line.world.size(); ++k)
  {
    built->problem->AddResidualBlock(new ceres::AutoDiffCostFunction<WorldPointToLineResidual, 2, 4>(
                                         new WorldPointToLineResidual{model.frame, line.world[k], model.world_weight}),
                                     makeLoss(s.options.loss, s.loss_scale_px).release(), model.q.data());
    built->residual_count += 2;
    built->row_group.push_back(i);
    built->row_group.push_back(i);
  }
}

// The paper's residuals of line i: each world point's projection to the image part paired with it.
void addWorldPointResiduals(RefinementState& s, size_t i, BuiltProblem* built)
{
  const auto& line = s.data.lines[i];
  Parameters& p = s.p;
  for (size_t k = 0; k < line.world.size(); ++k)
  {
    const Eigen::Vector2d a = line.image[s.assignment[i][k]];
    const Eigen::Vector2d b = line.image[s.assignment[i][k] + 1];
    const Eigen::Vector2d dir = (b - a).normalized();
    auto* cost = new ceres::AutoDiffCostFunction<PointToPartResidual, 1, 2, 2, 1, 1, 3, 3>(
        new PointToPartResidual{s.projector, line.world[k], a, Eigen::Vector2d(-dir.y(), dir.x()), s.line_weight[i]});
    built->problem->AddResidualBlock(cost, makeLoss(s.options.loss, s.loss_scale_px).release(), p.focal, p.principal,
                                     p.skew, p.distortion, p.delta, p.center);
    ++built->residual_count;
    built->row_group.push_back(i);
  }
}

// Direction lines (after the plumb lines in the row groups).
void addDirectionLineResiduals(RefinementState& s, BuiltProblem* built)
{
  const size_t first_group = s.data.lines.size() + s.data.points.size() + s.straight.params.size();
  Parameters& p = s.p;
  for (size_t k = 0; k < s.direction.phi.size(); ++k)
    for (const auto& m : s.direction.used[k] ? s.data.direction_lines[k].image : std::vector<Eigen::Vector2d>{})
    {
      const auto& [d, e1, e2] = s.direction.frames[k];
      built->problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<DirectionLineResidual, 1, 2, 2, 1, 1, 3, 3, 1, 1>(
              new DirectionLineResidual{s.projector, d, e1, e2, m, s.direction.weight[k]}),
          makeLoss(s.options.loss, s.loss_scale_px).release(), p.focal, p.principal, p.skew, p.distortion, p.delta,
          p.center, s.direction.phi[k].data(), s.direction.azimuthOf(s.data.direction_lines[k].azimuth_group));
      ++built->residual_count;
      built->row_group.push_back(first_group + k);
    }
  if (built->problem->HasParameterBlock(s.direction.exact.data()))
    built->problem->SetParameterBlockConstant(s.direction.exact.data());
}

// Point correspondences and plumb lines.
void addPointAndPlumbLineResiduals(RefinementState& s, BuiltProblem* built)
{
  const size_t lines = s.data.lines.size();
  Parameters& p = s.p;
  for (size_t k = 0; k < s.data.points.size(); ++k)
  {
    const auto& point = s.data.points[k];
    auto* cost = new ceres::AutoDiffCostFunction<PointResidual, 2, 2, 2, 1, 1, 3, 3>(
        new PointResidual{s.projector, point.world, point.image});
    built->problem->AddResidualBlock(cost, makeLoss(s.options.loss, s.loss_scale_px).release(), p.focal, p.principal,
                                     p.skew, p.distortion, p.delta, p.center);
    built->residual_count += 2;
    built->row_group.push_back(lines + k);
    built->row_group.push_back(lines + k);
  }
  for (size_t k = 0; k < s.straight.params.size(); ++k)
    for (const auto& m : s.straight.used[k] ? s.data.straight_lines[k] : std::vector<Eigen::Vector2d>{})
    {
      built->problem->AddResidualBlock(new ceres::AutoDiffCostFunction<StraightLineResidual, 1, 2, 1, 2>(
                                           new StraightLineResidual{s.projector.r_ref2, m}),
                                       makeLoss(s.options.loss, s.loss_scale_px).release(), p.principal, p.distortion,
                                       s.straight.params[k].data());
      ++built->residual_count;
      built->row_group.push_back(lines + s.data.points.size() + k);
    }
  addDirectionLineResiduals(s, built);
}

// Weak priors on the aspect ratio and the principal point, in the residuals' units (scaled by the residuals' noise
// level, so that both the solve and the covariance, which is scaled by the residual variance afterwards, see them
// with their own sigma); and the blocks the options hold fixed.
void addPriorsAndFixedBlocks(RefinementState& s, BuiltProblem* built)
{
  const RefinementOptions& options = s.options;
  Parameters& p = s.p;
  ceres::Problem& problem = *built->problem;
  const double noise = s.prior_noise_px;
  if (!options.single_focal && options.aspect_prior_sigma > 0.0)
  {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<AspectPrior, 1, 2>(new AspectPrior{noise / options.aspect_prior_sigma}),
        nullptr, p.focal);
    built->row_group.push_back(std::numeric_limits<size_t>::max());
  }
  if (options.estimate_principal_point && options.principal_point_prior_sigma > 0.0)
  {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PrincipalPointPrior, 2, 2>(new PrincipalPointPrior{
                                 options.principal_point_prior_center.value_or(s.data.imageCenter()),
                                 noise / (options.principal_point_prior_sigma * s.data.image_width)}),
                             nullptr, p.principal);
    built->row_group.push_back(std::numeric_limits<size_t>::max());
    built->row_group.push_back(std::numeric_limits<size_t>::max());
  }
  if (options.single_focal)
    problem.SetManifold(p.focal, new ceres::SubsetManifold(2, {1}));
  if (!options.estimate_skew)
    problem.SetParameterBlockConstant(p.skew);
  if (!options.estimate_distortion)
    problem.SetParameterBlockConstant(p.distortion);
  if (!options.estimate_principal_point)
    problem.SetParameterBlockConstant(p.principal);
}

Expected<BuiltProblem> buildProblem(RefinementState& s)
{
  BuiltProblem built;
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  built.problem = std::make_unique<ceres::Problem>(problem_options);
  const bool image_residuals = s.options.line_residual != LineResidual::kWorldPoints;
  const bool only_image_residuals =
      s.options.line_residual == LineResidual::kImagePoints || s.options.line_residual == LineResidual::kJoint;
  for (size_t i = 0; i < s.data.lines.size(); ++i)
  {
    if (!s.selected(i))
      continue;
    const bool image_points = image_residuals && s.hasLine(i);
    if (image_points)
      addImagePointResiduals(s, i, &built);
    if (!image_points || !only_image_residuals)
      addWorldPointResiduals(s, i, &built);
  }
  addPointAndPlumbLineResiduals(s, &built);
  if (built.residual_count == 0)
    return Error(ErrorCode::kNotEnoughData, "refinement has no residuals (no selected line or point)");
  addPriorsAndFixedBlocks(s, &built);
  return built;
}

ceres::Solver::Summary solve(ceres::Problem& problem, const RefinementOptions& options)
{
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = 1e-12;
  solver_options.gradient_tolerance = 1e-12;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  return summary;
}

// Per selected line with a 3D line: each image point's distance (px) to the distorted image of that line under the
// current parameters (kJoint: the free line as solved).
std::vector<std::vector<double>> imagePointDistances(const RefinementState& s)
{
  std::vector<std::vector<double>> distance(s.data.lines.size());
  for (size_t i = 0; i < s.data.lines.size(); ++i)
  {
    if (!s.selected(i) || !s.hasLine(i))
      continue;
    Eigen::Vector3d a = s.models[i].ends.a, b = s.models[i].ends.b;
    if (s.models[i].joint)
      s.models[i].frame.ends(s.models[i].q.data(), a.data(), b.data());
    const ImagePointToLineResidual functor{s.projector, a, b, Eigen::Vector2d()};
    for (const auto& m : s.data.lines[i].image)
    {
      ImagePointToLineResidual f = functor;
      f.image = m;
      double r = std::numeric_limits<double>::infinity();
      f(s.p.focal, s.p.principal, s.p.skew, s.p.distortion, s.p.delta, s.p.center, &r);
      distance[i].push_back(std::abs(r));
    }
  }
  return distance;
}

// The noise level of the matched lines' image points in use (1.4826 x median distance); NaN without any.
double usedImagePointNoise(const RefinementState& s, const std::vector<std::vector<double>>& distance)
{
  std::vector<double> all;
  for (size_t i = 0; i < distance.size(); ++i)
    for (size_t v = 0; v < distance[i].size(); ++v)
      if (s.vertex_used[i][v] && std::isfinite(distance[i][v]))
        all.push_back(distance[i][v]);
  return all.empty() ? std::numeric_limits<double>::quiet_NaN() : robustSigma(std::move(all));
}

// Image points far beyond the noise level of all image points are left out (a polyline that runs past the end of its
// edge onto the next one); a line keeps at least two. True when the set of points changed: the solve is repeated.
bool leaveOutImagePointOutliers(RefinementState& s)
{
  if (!(s.options.vertex_outlier_sigmas > 0.0) || s.options.line_residual == LineResidual::kWorldPoints)
    return false;
  const std::vector<std::vector<double>> distance = imagePointDistances(s);
  const double noise = usedImagePointNoise(s, distance);
  if (!std::isfinite(noise))
    return false;
  const double threshold = std::max(s.options.min_vertex_outlier_px, s.options.vertex_outlier_sigmas * noise);
  bool changed = false;
  for (size_t i = 0; i < distance.size(); ++i)
  {
    if (distance[i].empty())
      continue;
    std::vector<bool> used(distance[i].size());
    for (size_t v = 0; v < used.size(); ++v)
      used[v] = distance[i][v] <= threshold;
    if (std::count(used.begin(), used.end(), true) < 2)
      used.assign(used.size(), true);
    if (used != s.vertex_used[i])
    {
      s.vertex_used[i] = used;
      changed = true;
    }
  }
  return changed;
}

// A direction line's scatter about its own fitted line (px; its angle phi is one degree of freedom), NaN when it
// has no point to spare.
double directionLineScatter(const RefinementState& s, size_t k)
{
  const auto& points = s.data.direction_lines[k].image;
  if (points.size() < 2)
    return std::numeric_limits<double>::quiet_NaN();
  const auto& [d, e1, e2] = s.direction.frames[k];
  const double* azimuth = s.direction.azimuthOf(s.data.direction_lines[k].azimuth_group);
  double sum = 0.0;
  for (const auto& m : points)
  {
    const DirectionLineResidual f{s.projector, d, e1, e2, m};
    double r = 0.0;
    if (!f(s.p.focal, s.p.principal, s.p.skew, s.p.distortion, s.p.delta, s.p.center, s.direction.phi[k].data(),
           azimuth, &r))
      return std::numeric_limits<double>::quiet_NaN();
    sum += r * r;
  }
  return std::sqrt(sum / static_cast<double>(points.size() - 1));
}

// Direction lines noisier than the matched lines' image points (by more than direction_line_noise_ratio) are weighed
// as that noisy (their scatter over that noise, directionLineWeight); a weight only ever falls, so the rounds settle.
// True when a weight changed: the solve is repeated.
bool reweighDirectionLines(RefinementState& s)
{
  if (!(s.options.direction_line_noise_ratio > 0.0) || s.options.line_residual == LineResidual::kWorldPoints)
    return false;
  const double noise = usedImagePointNoise(s, imagePointDistances(s));
  if (!std::isfinite(noise) || !(noise > 0.0))
    return false;
  bool changed = false;
  for (size_t k = 0; k < s.direction.used.size(); ++k)
  {
    if (!s.direction.used[k])
      continue;
    const double scatter = directionLineScatter(s, k);
    if (!std::isfinite(scatter) || scatter <= s.options.direction_line_noise_ratio * noise)
      continue;
    const double weight = directionLineWeight(s.options, s.data.direction_lines[k].image.size(), scatter / noise);
    if (weight < 0.95 * s.direction.weight[k])
    {
      s.direction.weight[k] = weight;
      changed = true;
    }
  }
  return changed;
}

// The free blocks of the Jacobian. The plumb and direction lines' own parameters are nuisance parameters: in the normal
// equations (so that the camera's uncertainty accounts for them), not in the reported covariance.
FreeBlocks freeBlocksOf(RefinementState& s)
{
  FreeBlocks free;
  free.add(s.p.focal, s.options.single_focal ? 1 : 2);
  if (s.options.estimate_principal_point)
    free.add(s.p.principal, 2);
  if (s.options.estimate_skew)
    free.add(s.p.skew, 1);
  if (s.options.estimate_distortion)
    free.add(s.p.distortion, 1);
  free.add(s.p.delta, 3);
  free.add(s.p.center, 3);
  for (size_t k = 0; k < s.straight.params.size(); ++k)
    if (s.straight.used[k])
      free.add(s.straight.params[k].data(), 2);
  for (size_t k = 0; k < s.direction.phi.size(); ++k)
    if (s.direction.used[k])
      free.add(s.direction.phi[k].data(), 1);
  for (const int group : s.direction.usedAzimuthGroups(s.data))
    free.add(s.direction.azimuthOf(group), 1);
  return free;
}

// Every parameter the solve moved: the camera's, each kJoint line's 4, each plumb line's 2, each direction line's 1
// and each used azimuth group's 1.
size_t freeParameterCount(const RefinementState& s)
{
  size_t joint_lines = 0;
  for (size_t i = 0; i < s.data.lines.size(); ++i)
    joint_lines += s.selected(i) && s.models[i].joint ? 1 : 0;
  const RefinementOptions& o = s.options;
  return 4 * joint_lines + 2 * std::count(s.straight.used.begin(), s.straight.used.end(), true) +
         std::count(s.direction.used.begin(), s.direction.used.end(), true) +
         s.direction.usedAzimuthGroups(s.data).size() + (o.single_focal ? 1 : 2) +
         (o.estimate_principal_point ? 2 : 0) + (o.estimate_skew ? 1 : 0) + (o.estimate_distortion ? 1 : 0) + 6;
}

// The robust schedule: pair, solve, leave out image-point outliers, and again while the pairing (which matters only
// to world-point residuals) or the points used change, up to options.max_reassignments times.
Expected<BuiltProblem> solveRounds(RefinementState& s, RefinementResult* result, ceres::Solver::Summary* summary)
{
  const bool only_image_residuals =
      s.options.line_residual == LineResidual::kImagePoints || s.options.line_residual == LineResidual::kJoint;
  BuiltProblem built;
  bool vertices_changed = false;
  for (int round = 0; round <= s.options.max_reassignments; ++round)
  {
    const bool changed = pairWorldPointsWithParts(s);
    if (round > 0 && !vertices_changed && (!changed || only_image_residuals))
      break;
    Expected<BuiltProblem> next = buildProblem(s);
    if (!next)
      return next.error();
    built = std::move(*next);
    *summary = solve(*built.problem, s.options);
    result->iterations += static_cast<int>(summary->iterations.size());
    if (summary->termination_type == ceres::FAILURE)
      return Error(ErrorCode::kNoSolution, "refinement failed: " + summary->message);
    vertices_changed = leaveOutImagePointOutliers(s);
    vertices_changed = reweighDirectionLines(s) || vertices_changed;
  }
  return built;
}

// The fit's noise level (px): the plain squared residuals (the priors' left out, the robust loss not applied) over
// the degrees of freedom, as the covariance estimates it, at least kMinPriorNoisePx; NaN without redundancy.
double fitNoiseLevel(const RefinementState& s, BuiltProblem& built)
{
  ceres::Problem::EvaluateOptions evaluate_options;
  evaluate_options.apply_loss_function = false;
  std::vector<double> residuals;
  if (!built.problem->Evaluate(evaluate_options, nullptr, &residuals, nullptr, nullptr))
    return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  size_t rows = 0;
  for (size_t r = 0; r < residuals.size() && r < built.row_group.size(); ++r)
    if (built.row_group[r] != std::numeric_limits<size_t>::max())
    {
      sum += residuals[r] * residuals[r];
      ++rows;
    }
  const size_t free = freeParameterCount(s);
  if (rows <= free)
    return std::numeric_limits<double>::quiet_NaN();
  return std::max(kMinPriorNoisePx, std::sqrt(sum / static_cast<double>(rows - free)));
}

bool hasPriors(const RefinementOptions& o)
{
  return (!o.single_focal && o.aspect_prior_sigma > 0.0) ||
         (o.estimate_principal_point && o.principal_point_prior_sigma > 0.0);
}

// The rounds again while the priors' noise level is not the fit's: guessed from the initial camera's residuals it
// can be several times the fit's (a DLT start 2 px off, a fit at 0.15 px), which would make a prior of 3 % of the
// width act as one of 0.5 % in the solve and in the covariance alike, and pull a principal point 3 % off centre
// many of its sigmas off.
Expected<BuiltProblem> solveWithConsistentPriors(RefinementState& s, RefinementResult* result,
                                                 ceres::Solver::Summary* summary)
{
  Expected<BuiltProblem> built = solveRounds(s, result, summary);
  for (int pass = 0; built && s.options.priors_at_fit_noise && hasPriors(s.options) && pass < kMaxPriorNoisePasses;
       ++pass)
  {
    const double fit = fitNoiseLevel(s, *built);
    if (!std::isfinite(fit) || std::abs(fit / s.prior_noise_px - 1.0) < kPriorNoiseTolerance)
      break;
    s.prior_noise_px = fit;
    built = solveRounds(s, result, summary);
  }
  return built;
}

// Per-line diagnostics and the uncertainty, from the last round's problem at the optimum.
void analyseSolution(RefinementState& s, BuiltProblem& built, RefinementResult* result)
{
  const size_t lines = s.data.lines.size();
  const FreeBlocks free = freeBlocksOf(s);
  const GroupDiagnostics groups = analyseGroups(
      *built.problem, free, built.row_group,
      lines + s.data.points.size() + s.straight.params.size() + s.direction.phi.size(),
      s.options.compute_uncertainty && s.options.per_line_uncertainty && s.options.pair_uncertainty ? lines : 0);
  result->line_rms_px.assign(groups.rms_px.begin(), groups.rms_px.begin() + lines);
  result->line_loo_rms_px.assign(groups.loo_rms_px.begin(), groups.loo_rms_px.begin() + lines);
  result->line_influence.assign(groups.influence.begin(), groups.influence.begin() + lines);
  if (!s.options.compute_uncertainty)
    return;
  CameraUncertainty& u = result->uncertainty;
  u.reciprocal_condition = groups.reciprocal_condition;
  computeCameraCovariance(*built.problem, s.p, built.residual_count, freeParameterCount(s), s.projector.r_ref2,
                          s.options.single_focal, &u);
  if (u.available && s.options.per_line_uncertainty && groups.jackknife.rows() == free.columns())
    widenByJackknife(groups.jackknife, free, s.p, s.projector.r_ref2, s.options.single_focal, &u);
  if (u.available && s.options.per_line_uncertainty && groups.pair_jackknife.rows() == free.columns())
    widenByJackknife(groups.pair_jackknife, free, s.p, s.projector.r_ref2, s.options.single_focal, &u);
}

// Two orthonormal directions across a 3D line.
std::array<Eigen::Vector3d, 2> directionsAcross(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  const Eigen::Vector3d u = (b - a).normalized();
  const Eigen::Vector3d e1 = u.unitOrthogonal();
  return {e1, u.cross(e1)};
}

// How line i's residual rows (in buildProblem's order) change when its 3D line moves rigidly by each of `moves`
// (one column each): central differences of its own functors (the residuals are linear in so small a move).
Eigen::MatrixXd lineMoveRows(const RefinementState& s, size_t i, const std::vector<Eigen::Vector3d>& moves)
{
  const auto& line = s.data.lines[i];
  const Parameters& p = s.p;
  const bool image_points = s.options.line_residual != LineResidual::kWorldPoints && s.hasLine(i);
  const bool world_points = !image_points || s.options.line_residual == LineResidual::kBoth;
  std::vector<Eigen::VectorXd> rows;
  const auto move = [&](const auto& residual_at) {
    Eigen::VectorXd row(moves.size());
    for (size_t k = 0; k < moves.size(); ++k)
      row(k) = 0.5 * (residual_at(moves[k]) - residual_at(-moves[k]));
    rows.push_back(row);
  };
  for (size_t v = 0; image_points && v < line.image.size(); ++v)
    if (s.vertex_used[i][v])
      move([&](const Eigen::Vector3d& d) {
        const ImagePointToLineResidual f{s.projector, s.models[i].ends.a + d, s.models[i].ends.b + d, line.image[v],
                                         s.line_weight[i]};
        double r = 0.0;
        f(p.focal, p.principal, p.skew, p.distortion, p.delta, p.center, &r);
        return r;
      });
  for (size_t k = 0; world_points && k < line.world.size(); ++k)
    move([&](const Eigen::Vector3d& d) {
      const Eigen::Vector2d a = line.image[s.assignment[i][k]], b = line.image[s.assignment[i][k] + 1];
      const Eigen::Vector2d dir = (b - a).normalized();
      const PointToPartResidual f{s.projector, line.world[k] + d, a, Eigen::Vector2d(-dir.y(), dir.x()),
                                  s.line_weight[i]};
      double r = 0.0;
      f(p.focal, p.principal, p.skew, p.distortion, p.delta, p.center, &r);
      return r;
    });
  Eigen::MatrixXd out(rows.size(), moves.size());
  for (size_t r = 0; r < rows.size(); ++r)
    out.row(r) = rows[r].transpose();
  return out;
}

// The camera's parameters moved by each line's moves (moves_of(i): rigid moves of line i's 3D line, none to leave
// it), linearised through the problem refineCamera solves at its optimum `camera` (the same weights, plumb lines,
// pairing and priors): per line, free parameters x moves. Empty on failure.
template <typename MovesOf>
std::vector<Eigen::MatrixXd> cameraShiftsOfLineMoves(const CorrespondenceSet& data, const CameraModel& camera,
                                                     const RefinementOptions& options, const MovesOf& moves_of,
                                                     CameraColumns* columns, double* r_ref2)
{
  const std::vector<bool> all_lines;
  RefinementState s(data, options, all_lines, camera);
  s.line_weight = worldSigmaWeights(s);
  s.models = makeLineModels(data, options, NoiseLevels());
  s.straight = fitStraightLines(s);
  s.direction = fitDirectionLines(s);
  s.assignment.resize(data.lines.size());
  for (const auto& line : data.lines)
    s.vertex_used.emplace_back(line.image.size(), true);
  pairWorldPointsWithParts(s);
  reweighDirectionLines(s);  // as the solve weighed them at its optimum
  s.prior_noise_px = kMinPriorNoisePx;
  Expected<BuiltProblem> built = buildProblem(s);
  // As refineCamera's solve ended with priors_at_fit_noise: the priors scaled by the fit's noise at `camera`.
  if (const double fit = built && hasPriors(options) ? fitNoiseLevel(s, *built) : 0.0; std::isfinite(fit) && fit > 0.0)
  {
    s.prior_noise_px = fit;
    built = buildProblem(s);
  }
  if (!built)
    return {};
  std::vector<Eigen::MatrixXd> rows(data.lines.size());
  for (size_t i = 0; i < data.lines.size(); ++i)
  {
    const std::vector<Eigen::Vector3d> moves = moves_of(i);
    if (!moves.empty() && data.lines[i].world.size() >= 2)
      rows[i] = lineMoveRows(s, i, moves);
  }
  const FreeBlocks free = freeBlocksOf(s);
  *columns = cameraColumns(free, s.p);
  *r_ref2 = s.projector.r_ref2;
  return groupShifts(*built->problem, free, built->row_group, rows);
}

Status checkLineInput(const CorrespondenceSet& data, const RefinementOptions& options, size_t per_line)
{
  if (const Status valid = data.validate(); !valid)
    return valid.error();
  if (per_line != data.lines.size())
    return Error(ErrorCode::kInvalidInput,
                 std::to_string(per_line) + " line errors for " + std::to_string(data.lines.size()) + " lines");
  if (options.line_residual == LineResidual::kJoint)
    return Error(ErrorCode::kInvalidInput, "the joint error model estimates the 3D lines itself");
  return Success{};
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
  RefinementState s(data, options, use_line, initial);

  RefinementResult result;
  {
    // The starting error, with the pairing of points and parts the initial camera gives.
    const std::vector<double> r = selectedLineResiduals(s, s.camera());
    result.initial_rms_px = rootMeanSquare(r);
    result.loss_scale_px = options.loss_scale_px;
    if (!(result.loss_scale_px > 0.0))
      result.loss_scale_px = std::max(0.5, 2.5 * summarize(r).median_px / 0.6745);
    s.loss_scale_px = result.loss_scale_px;
    s.prior_noise_px = std::max(kMinPriorNoisePx, s.loss_scale_px / 2.5);
  }
  s.line_weight = worldSigmaWeights(s);
  // kJoint: the noise levels (given or estimated with the initial distortion) and each line's 3D line.
  NoiseLevels noise;
  if (options.line_residual == LineResidual::kJoint)
  {
    noise = estimateNoiseLevels(data, initial.distortion(), options.image_sigma_px, options.world_sigma_m);
    result.image_sigma_px = noise.image_sigma_px;
    result.world_sigma_m = noise.world_sigma_m;
  }
  s.models = makeLineModels(data, options, noise);
  s.straight = fitStraightLines(s);
  s.direction = fitDirectionLines(s);
  s.assignment.resize(data.lines.size());
  for (const auto& line : data.lines)
    s.vertex_used.emplace_back(line.image.size(), true);

  ceres::Solver::Summary summary;
  Expected<BuiltProblem> built = solveWithConsistentPriors(s, &result, &summary);
  if (!built)
    return built.error();
  result.camera = s.camera();
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.termination = summary.message;
  result.residuals = built->residual_count;
  result.final_rms_px = rootMeanSquare(selectedLineResiduals(s, result.camera));
  analyseSolution(s, *built, &result);
  return result;
}

Expected<CameraUncertainty> propagateWorldLineErrors(const CorrespondenceSet& data, const CameraModel& camera,
                                                     const RefinementOptions& options,
                                                     const std::vector<std::vector<Eigen::Vector3d>>& error_modes)
{
  if (const Status valid = checkLineInput(data, options, error_modes.size()); !valid)
    return valid.error();
  CameraColumns columns;
  double r_ref2 = 1.0;
  const std::vector<Eigen::MatrixXd> shifts = cameraShiftsOfLineMoves(
      data, camera, options, [&](size_t i) { return error_modes[i]; }, &columns, &r_ref2);
  if (shifts.size() != data.lines.size())
    return Error(ErrorCode::kNoSolution, "the lines' errors could not be propagated to the camera");
  Eigen::MatrixXd covariance;
  for (const Eigen::MatrixXd& shift : shifts)
    if (shift.size() > 0)
      covariance = covariance.size() > 0 ? Eigen::MatrixXd(covariance + shift * shift.transpose())
                                         : Eigen::MatrixXd(shift * shift.transpose());
  if (covariance.size() == 0)
    return Error(ErrorCode::kInvalidInput, "no line has an error to propagate");
  CameraUncertainty u;
  setSigmasFromCovariance(covariance, columns, r_ref2, options.single_focal, &u);
  return u;
}

std::vector<std::vector<Eigen::Vector3d>> errorsAcrossLines(const CorrespondenceSet& data,
                                                            const std::vector<double>& sigmas_m)
{
  std::vector<std::vector<Eigen::Vector3d>> modes(data.lines.size());
  for (size_t i = 0; i < data.lines.size() && i < sigmas_m.size(); ++i)
    if (sigmas_m[i] > 0.0 && data.lines[i].world.size() >= 2)
      for (const Eigen::Vector3d& e : directionsAcross(data.lines[i].world.front(), data.lines[i].world.back()))
        modes[i].push_back(sigmas_m[i] * e);
  return modes;
}

Expected<CameraShift> predictCameraShift(const CorrespondenceSet& data, const CameraModel& camera,
                                         const RefinementOptions& options, const std::vector<Eigen::Vector3d>& moves_m)
{
  if (const Status valid = checkLineInput(data, options, moves_m.size()); !valid)
    return valid.error();
  const auto moves_of = [&](size_t i) {
    return moves_m[i].norm() > 0.0 ? std::vector<Eigen::Vector3d>{moves_m[i]} : std::vector<Eigen::Vector3d>{};
  };
  CameraColumns columns;
  double r_ref2 = 1.0;
  const std::vector<Eigen::MatrixXd> shifts =
      cameraShiftsOfLineMoves(data, camera, options, moves_of, &columns, &r_ref2);
  if (shifts.size() != data.lines.size())
    return Error(ErrorCode::kNoSolution, "the lines' moves could not be propagated to the camera");
  CameraShift out;
  const int f = columns.focal, d = columns.delta, c = columns.center;
  for (const Eigen::MatrixXd& shift : shifts)
    if (shift.size() > 0)
    {
      out.fx_px += shift(f, 0);
      out.lambda += columns.distortion >= 0 ? shift(columns.distortion, 0) / r_ref2 : 0.0;
      out.rotation_rad += shift.block(d, 0, 3, 1);
      out.center_m += shift.block(c, 0, 3, 1);
    }
  return out;
}

}  // namespace insitu_calibration
