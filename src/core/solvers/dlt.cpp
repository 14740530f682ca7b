#include "insitu_calibration/solvers/dlt.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "insitu_calibration/solvers/decomposition.h"
#include "insitu_calibration/solvers/dlt_lines.h"
#include "insitu_calibration/solvers/dlt_points.h"
#include "insitu_calibration/solvers/dlt_system.h"
#include "insitu_calibration/solvers/generalized_eigen.h"
#include "insitu_calibration/solvers/normalization.h"

namespace insitu_calibration
{
namespace
{
bool usesLines(DltMethod method)
{
  return method != DltMethod::kPoints;
}
bool usesPoints(DltMethod method)
{
  return method != DltMethod::kLines;
}

// In normalised 3D coordinates (mean distance sqrt(3)) a spread below this is taken as exactly degenerate.
constexpr double kDegenerateSpread = 1e-6;

std::vector<Eigen::Vector3d> selectedWorldPoints(const CorrespondenceSet& data, DltMethod method)
{
  std::vector<Eigen::Vector3d> world;
  if (usesLines(method))
    for (const auto& line : data.lines)
      world.insert(world.end(), line.world.begin(), line.world.end());
  if (usesPoints(method))
    for (const auto& p : data.points)
      world.push_back(p.world);
  return world;
}

// Smallest over largest eigenvalue of the scatter of the normalised points: zero when they are coplanar.
bool allCoplanar(const std::vector<Eigen::Vector3d>& world, const WorldNormalization& norm)
{
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& x : world)
  {
    const Eigen::Vector3d y = norm.apply(x);
    scatter += y * y.transpose();
  }
  scatter /= static_cast<double>(world.size());
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();
  return std::sqrt(std::max(ev(0), 0.0)) < kDegenerateSpread * std::sqrt(ev(2));
}

// Hartley's image and world normalisations together, in two passes over the data (centroids, then mean
// distances): on 10^6 constraints the passes over memory cost more than the arithmetic.
void computeNormalizations(const CorrespondenceSet& data, DltMethod method,
                           const std::optional<Eigen::Vector2d>& image_origin, ImageNormalization* image_norm,
                           WorldNormalization* world_norm)
{
  const bool lines = usesLines(method);
  const bool points = usesPoints(method);
  Eigen::Vector2d image_sum = Eigen::Vector2d::Zero();
  Eigen::Vector3d world_sum = Eigen::Vector3d::Zero();
  size_t image_count = 0;
  size_t world_count = 0;
  if (lines)
    for (const auto& line : data.lines)
    {
      for (const auto& m : line.image)
        image_sum += m;
      for (const auto& x : line.world)
        world_sum += x;
      image_count += line.image.size();
      world_count += line.world.size();
    }
  if (points)
    for (const auto& p : data.points)
    {
      image_sum += p.image;
      world_sum += p.world;
    }
  image_count += points ? data.points.size() : 0;
  world_count += points ? data.points.size() : 0;
  if (image_count == 0 || world_count == 0)
    return;
  image_norm->origin = image_origin ? *image_origin : Eigen::Vector2d(image_sum / image_count);
  world_norm->origin = world_sum / world_count;
  double image_distance = 0.0;
  double world_distance = 0.0;
  if (lines)
    for (const auto& line : data.lines)
    {
      for (const auto& m : line.image)
        image_distance += (m - image_norm->origin).norm();
      for (const auto& x : line.world)
        world_distance += (x - world_norm->origin).norm();
    }
  if (points)
    for (const auto& p : data.points)
    {
      image_distance += (p.image - image_norm->origin).norm();
      world_distance += (p.world - world_norm->origin).norm();
    }
  image_norm->scale = image_distance > 0.0 ? std::sqrt(2.0) * image_count / image_distance : 1.0;
  world_norm->scale = world_distance > 0.0 ? std::sqrt(3.0) * world_count / world_distance : 1.0;
}

struct LineGeometry
{
  Eigen::Vector3d point;
  Eigen::Vector3d direction;
};

// Lines through one point: the least-squares closest point to all lines is on every one of them.
Status checkLineGeometry(const std::vector<LineGeometry>& lines)
{
  if (lines.size() < 2)
    return Success{};
  Eigen::Matrix3d directions = Eigen::Matrix3d::Zero();
  for (const auto& l : lines)
    directions += l.direction * l.direction.transpose();
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(directions).eigenvalues();
  if (ev(1) < kDegenerateSpread * kDegenerateSpread * ev(2))
    return Error(ErrorCode::kDegenerate,
                 "all 3D lines are parallel, which leaves the camera undetermined; add lines "
                 "in other directions");
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& l : lines)
  {
    const Eigen::Matrix3d orth = Eigen::Matrix3d::Identity() - l.direction * l.direction.transpose();
    a += orth;
    b += orth * l.point;
  }
  const Eigen::Vector3d x = a.ldlt().solve(b);
  double worst = 0.0;
  for (const auto& l : lines)
    worst =
        std::max(worst, ((Eigen::Matrix3d::Identity() - l.direction * l.direction.transpose()) * (x - l.point)).norm());
  if (x.allFinite() && worst < kDegenerateSpread)
    return Error(ErrorCode::kDegenerate, "all 3D lines pass through one point, which leaves the camera undetermined");
  return Success{};
}
}  // namespace

std::optional<DltMethod> parseDltMethod(const std::string& name)
{
  if (name == "lines")
    return DltMethod::kLines;
  if (name == "points")
    return DltMethod::kPoints;
  if (name == "combined")
    return DltMethod::kCombined;
  return std::nullopt;
}

const char* toString(DltMethod method)
{
  switch (method)
  {
    case DltMethod::kLines:
      return "lines";
    case DltMethod::kPoints:
      return "points";
    case DltMethod::kCombined:
      return "combined";
  }
  return "?";
}

Status checkDltInput(const CorrespondenceSet& data, const DltOptions& options)
{
  if (const Status valid = data.validate(); !valid)
    return valid;
  const bool lines = usesLines(options.method) && !data.lines.empty();
  const bool points = usesPoints(options.method) && !data.points.empty();
  if (options.method == DltMethod::kLines && data.lines.empty())
    return Error(ErrorCode::kNotEnoughData, "method 'lines' needs line correspondences and there are none");
  if (options.method == DltMethod::kPoints && data.points.empty())
    return Error(ErrorCode::kNotEnoughData, "method 'points' needs point correspondences and there are none");

  // Independent equations: a 3D line gives at most two (a third point on it is a combination of two), a point two.
  size_t equations = 0;
  if (lines)
    for (const auto& line : data.lines)
      equations += std::min<size_t>(line.world.size(), 2);
  if (points)
    equations += 2 * data.points.size();
  const size_t needed = options.estimate_distortion ? 12 : 11;
  if (equations < needed)
    return Error(ErrorCode::kNotEnoughData,
                 "the data give " + std::to_string(equations) + " independent equations and the camera" +
                     (options.estimate_distortion ? " with distortion" : "") + " needs " + std::to_string(needed) +
                     " (a 3D line gives at most 2, with 2 or more world points; a point gives 2)");
  if (lines && !points && data.lines.size() < 6)
    return Error(ErrorCode::kNotEnoughData,
                 "DLT-Lines needs at least 6 lines in general position, got " + std::to_string(data.lines.size()));
  if (points && !lines && data.points.size() < 6)
    return Error(ErrorCode::kNotEnoughData,
                 "DLT-Points needs at least 6 points, got " + std::to_string(data.points.size()));
  if (options.estimate_distortion)
  {
    bool identifiable = points;
    if (lines)
      for (const auto& line : data.lines)
        identifiable = identifiable || line.image.size() >= 3;
    if (!identifiable)
      return Error(ErrorCode::kNotEnoughData,
                   "estimating distortion needs image lines of 3 or more points (a curved line) or point "
                   "correspondences; every line here has only its two end points");
  }

  const std::vector<Eigen::Vector3d> world = selectedWorldPoints(data, options.method);
  const WorldNormalization norm = computeWorldNormalization(world);
  if (allCoplanar(world, norm))
    return Error(ErrorCode::kDegenerate,
                 "all 3D points lie in one plane, which leaves the camera undetermined "
                 "(a plane only fixes a homography); add data off that plane");
  if (lines && !points)
  {
    std::vector<LineGeometry> geometry;
    for (const auto& line : data.lines)
    {
      if (line.world.size() < 2)
        continue;
      const Eigen::Vector3d a = norm.apply(line.world.front());
      const Eigen::Vector3d b = norm.apply(line.world.back());
      if ((b - a).norm() > kDegenerateSpread)
        geometry.push_back({a, (b - a).normalized()});
    }
    if (const Status s = checkLineGeometry(geometry); !s)
      return s;
  }
  return Success{};
}

Expected<DltLinearSolution> solveDltLinear(const CorrespondenceSet& data, const DltOptions& options,
                                           const Eigen::Vector2d& center)
{
  ImageNormalization image_norm;
  WorldNormalization world_norm;
  if (options.estimate_distortion)
    image_norm.origin = center;  // the division model is only invariant to scaling about its centre
  if (options.normalize)
  {
    computeNormalizations(data, options.method,
                          options.estimate_distortion ? std::optional<Eigen::Vector2d>(center) : std::nullopt,
                          &image_norm, &world_norm);
  }

  DltSystem system;
  if (usesLines(options.method))
    for (const auto& line : data.lines)
      addLineConstraints(line, image_norm, world_norm, &system);
  if (usesPoints(options.method))
    for (const auto& point : data.points)
      addPointConstraints(point, image_norm, world_norm, &system);

  const auto solved = solveDltSystem(system, options.estimate_distortion, options.polish_lambda);
  if (!solved)
    return solved.error();
  const Eigen::Map<const Matrix34d> normalized_p(solved->p.data());
  DltLinearSolution out;
  out.projection = image_norm.inverseMatrix() * normalized_p * world_norm.matrix();
  out.lambda = solved->lambda * image_norm.scale * image_norm.scale;
  out.center = center;
  out.algebraic_residual = solved->residual;
  out.null_space_gap = solved->null_space_gap;
  out.constraints = system.constraintCount();
  if (!out.projection.allFinite() || !std::isfinite(out.lambda))
    return Error(ErrorCode::kNoSolution, "the linear solve produced NaN or infinite values");
  return out;
}

Expected<DltResult> solveDlt(const CorrespondenceSet& data, const DltOptions& options)
{
  if (const Status s = checkDltInput(data, options); !s)
    return s.error();
  const std::vector<Eigen::Vector3d> world = selectedWorldPoints(data, options.method);

  const bool iterate = options.estimate_distortion && options.recenter_distortion && !options.distortion_center;
  Eigen::Vector2d center = options.distortion_center.value_or(data.imageCenter());
  DltResult result;
  result.center_converged = !iterate;
  for (int iteration = 0;; ++iteration)
  {
    auto linear = solveDltLinear(data, options, center);
    if (!linear)
      return linear.error();
    if (linear->null_space_gap < 1e-12)
      return Error(ErrorCode::kDegenerate,
                   "the correspondences leave more than one camera that fits them exactly "
                   "(the configuration is degenerate); add lines in other directions and "
                   "depths");
    if (options.estimate_distortion)
    {
      // The model must stay one-to-one over the image: 1 + lambda r^2 > 0 (barrel) and lambda r^2 < 1 (pincushion).
      double r2 = 0.0;
      for (double x : {0.0, data.image_width - 1.0})
        for (double y : {0.0, data.image_height - 1.0})
          r2 = std::max(r2, (Eigen::Vector2d(x, y) - center).squaredNorm());
      if (std::abs(linear->lambda) * r2 > 0.8)
        return Error(ErrorCode::kNoSolution,
                     "the estimated distortion (lambda " + std::to_string(linear->lambda) +
                         " 1/px^2) would fold the image onto itself; the data do not determine it (add curved lines "
                         "near the image border) or the correspondences are wrong");
    }
    auto decomposed = decomposeProjection(linear->projection, world);
    if (!decomposed)
      return decomposed.error();

    result.projection = decomposed->projection;
    result.camera =
        CameraModel(decomposed->intrinsics,
                    DivisionModel{options.estimate_distortion ? linear->lambda : 0.0,
                                  options.estimate_distortion ? center : decomposed->intrinsics.principalPoint()},
                    decomposed->pose);
    result.algebraic_residual = linear->algebraic_residual;
    result.null_space_gap = linear->null_space_gap;
    result.constraints = linear->constraints;
    result.center_iterations = iteration + 1;
    if (!iterate)
      break;
    const Eigen::Vector2d principal_point = decomposed->intrinsics.principalPoint();
    result.center_last_step_px = (principal_point - center).norm();
    if (!principal_point.allFinite())
      return Error(ErrorCode::kNoSolution, "the principal-point iteration produced a non-finite centre");
    if (result.center_last_step_px <= options.center_tolerance_px)
    {
      result.center_converged = true;
      break;
    }
    if (iteration + 1 >= options.max_center_iterations)
      break;
    center = principal_point;
  }
  result.lines_used = usesLines(options.method) ? data.lines.size() : 0;
  result.points_used = usesPoints(options.method) ? data.points.size() : 0;
  result.distortion_estimated = options.estimate_distortion;
  return result;
}

}  // namespace insitu_calibration
