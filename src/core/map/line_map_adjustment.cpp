#include "insitu_calibration/map/line_map_adjustment.h"

#include <cmath>
#include <algorithm>
#include <limits>
#include <memory>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "insitu_calibration/cpu_time.h"

namespace insitu_calibration
{
namespace
{
// A map line's four parameters relative to its start: point c0 + u1 e1 + u2 e2, direction d0 + v1 e1 + v2 e2
// (normalised), e1, e2 unit and orthogonal to d0.
struct LineBasis
{
  Eigen::Vector3d c0, d0, e1, e2;
  explicit LineBasis(const AdjustedLine& l)
      : c0(l.point), d0(l.direction.normalized()), e1(d0.unitOrthogonal()), e2(d0.cross(e1))
  {}
  template <typename T>
  void line(const T* p, Eigen::Matrix<T, 3, 1>* c, Eigen::Matrix<T, 3, 1>* d) const
  {
    *c = c0.cast<T>() + p[0] * e1.cast<T>() + p[1] * e2.cast<T>();
    *d = (d0.cast<T>() + p[2] * e1.cast<T>() + p[3] * e2.cast<T>()).normalized();
  }
  AdjustedLine adjusted(const double* p) const
  {
    Eigen::Vector3d c, d;
    line(p, &c, &d);
    return {c, d};
  }
};

// A map point into the corrected camera frame: x_cam = R^T Rz(yaw)^T (x - t - (dx, dy, 0)).
template <typename T>
Eigen::Matrix<T, 3, 1> toCamera(const Eigen::Isometry3d& tf, const T* pose, const Eigen::Matrix<T, 3, 1>& x)
{
  Eigen::Matrix<T, 3, 1> v = x - tf.translation().cast<T>();
  v.x() -= pose[0];
  v.y() -= pose[1];
  const T c = cos(pose[2]), s = sin(pose[2]);
  const Eigen::Matrix<T, 3, 1> u(c * v.x() + s * v.y(), -s * v.x() + c * v.y(), v.z());
  return tf.linear().transpose().cast<T>() * u;
}

// The residuals of one observation: two 2D point-to-line distances (px / sigma) and two depth offsets (m / sigma).
struct ObservationResidual
{
  const Eigen::Isometry3d* tf;
  const LineBasis* basis;
  Eigen::Vector3d image_a, image_b;  // homogeneous normalised points
  Eigen::Vector3d depth_a, depth_b;  // camera frame
  Eigen::Vector3d depth_direction;   // in the interpretation plane, across the observed line
  double focal_over_sigma_px, inverse_sigma_depth;

  template <typename T>
  bool operator()(const T* pose, const T* line, T* r) const
  {
    Eigen::Matrix<T, 3, 1> c, d;
    basis->line(line, &c, &d);
    const Eigen::Matrix<T, 3, 1> p = toCamera(*tf, pose, c);
    const Eigen::Matrix<T, 3, 1> q = toCamera(*tf, pose, Eigen::Matrix<T, 3, 1>(c + d));
    const Eigen::Matrix<T, 3, 1> dc = (q - p).normalized();
    const Eigen::Matrix<T, 3, 1> m = p.cross(q);  // normal of the map line's interpretation plane
    const T scale = T(focal_over_sigma_px) / sqrt(m.x() * m.x() + m.y() * m.y());
    r[0] = m.dot(image_a.cast<T>()) * scale;
    r[1] = m.dot(image_b.cast<T>()) * scale;
    auto across = [&](const Eigen::Vector3d& x) {
      const Eigen::Matrix<T, 3, 1> v = x.cast<T>() - p;
      return (v - v.dot(dc) * dc).dot(depth_direction.cast<T>()) * T(inverse_sigma_depth);
    };
    r[2] = across(depth_a);
    r[3] = across(depth_b);
    return true;
  }
};

struct PosePrior
{
  double inverse_sigma_m, inverse_sigma_rad;
  template <typename T>
  bool operator()(const T* pose, T* r) const
  {
    r[0] = pose[0] * T(inverse_sigma_m);
    r[1] = pose[1] * T(inverse_sigma_m);
    r[2] = pose[2] * T(inverse_sigma_rad);
    return true;
  }
};

// The localiser's error as a stationary Gauss-Markov process (correlation time tau): the correction of a keyframe
// given the previous one, c1 - rho c0 with rho = exp(-dt / tau), has the sigma sigma * sqrt(1 - rho^2). With a
// PosePrior on the chain's first keyframe this is the process's exact joint density. A localiser that wanders slowly
// tells the adjustment far less than one independent prior per keyframe would claim, and such priors would pull whole
// stretches of keyframes the same wrong way where its error is smooth.
struct MarkovPosePrior
{
  double rho, inverse_sigma_m, inverse_sigma_rad;
  template <typename T>
  bool operator()(const T* previous, const T* pose, T* r) const
  {
    r[0] = (pose[0] - T(rho) * previous[0]) * T(inverse_sigma_m);
    r[1] = (pose[1] - T(rho) * previous[1]) * T(inverse_sigma_m);
    r[2] = (pose[2] - T(rho) * previous[2]) * T(inverse_sigma_rad);
    return true;
  }
};

// The localiser's prior on every keyframe's correction: independent per keyframe (localization_correlation_s 0), or
// the Gauss-Markov chain over the keyframes in the order they came (as odometry ties them). A keyframe whose stamp is
// not after its predecessor's (a bag played again, a clock reset) or that starts another recording starts a new
// chain.
void addLocalizationPriors(const std::vector<Keyframe>& keyframes, const LineMapAdjustmentOptions& options,
                           std::vector<Eigen::Vector3d>* pose, ceres::Problem* problem)
{
  const double inverse_m = 1.0 / options.localization_sigma_m;
  const double inverse_rad = 180.0 / (M_PI * options.localization_sigma_deg);
  for (size_t k = 0; k < keyframes.size(); ++k)
  {
    const double dt = k > 0 ? keyframes[k].stamp - keyframes[k - 1].stamp : 0.0;
    if (!(options.localization_correlation_s > 0.0 && dt > 0.0) || keyframes[k].starts_recording)
    {
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<PosePrior, 3, 3>(new PosePrior{inverse_m, inverse_rad}),
                                nullptr, (*pose)[k].data());
      continue;
    }
    const double rho = std::exp(-dt / options.localization_correlation_s);
    // Keyframes a moment apart share the error: held together to at most a thousandth of its sigma.
    const double scale = 1.0 / std::sqrt(std::max(1e-6, 1.0 - rho * rho));
    problem->AddResidualBlock(new ceres::AutoDiffCostFunction<MarkovPosePrior, 3, 3, 3>(
                                  new MarkovPosePrior{rho, scale * inverse_m, scale * inverse_rad}),
                              nullptr, (*pose)[k - 1].data(), (*pose)[k].data());
  }
}

// Consecutive keyframes' relative motion (corrected poses) against odometry's: translation (m / sigma) and
// rotation (angle-axis, rad / sigma).
struct OdometryResidual
{
  const Eigen::Isometry3d* tf0;
  const Eigen::Isometry3d* tf1;
  Eigen::Isometry3d odometry;  // camera 1 in camera 0
  double inverse_sigma_m, inverse_sigma_rad;

  template <typename T>
  static Eigen::Matrix<T, 3, 3> rotation(const Eigen::Isometry3d& tf, const T* pose)
  {
    const T c = cos(pose[2]), s = sin(pose[2]);
    Eigen::Matrix<T, 3, 3> rz;
    rz << c, -s, T(0), s, c, T(0), T(0), T(0), T(1);
    return rz * tf.linear().cast<T>();
  }
  template <typename T>
  bool operator()(const T* pose0, const T* pose1, T* r) const
  {
    const Eigen::Matrix<T, 3, 3> r0 = rotation(*tf0, pose0), r1 = rotation(*tf1, pose1);
    Eigen::Matrix<T, 3, 1> t0 = tf0->translation().cast<T>(), t1 = tf1->translation().cast<T>();
    t0.x() += pose0[0];
    t0.y() += pose0[1];
    t1.x() += pose1[0];
    t1.y() += pose1[1];
    const Eigen::Matrix<T, 3, 1> dt = r0.transpose() * (t1 - t0) - odometry.translation().cast<T>();
    const Eigen::Matrix<T, 3, 3> dr = odometry.linear().transpose().cast<T>() * r0.transpose() * r1;
    T angle_axis[3];
    ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(dr.data()), angle_axis);
    for (int i = 0; i < 3; ++i)
    {
      r[i] = dt(i) * T(inverse_sigma_m);
      r[3 + i] = angle_axis[i] * T(inverse_sigma_rad);
    }
    return true;
  }
};

void addOdometry(const std::vector<Keyframe>& keyframes, const LineMapAdjustmentOptions& options,
                 std::vector<Eigen::Vector3d>* pose, ceres::Problem* problem)
{
  if (!(options.odometry_sigma_m > 0.0))
    return;
  for (size_t k = 1; k < keyframes.size(); ++k)
  {
    const Keyframe &a = keyframes[k - 1], &b = keyframes[k];
    if (!a.has_odometry || !b.has_odometry || b.starts_recording)
      continue;
    const Eigen::Isometry3d motion = a.T_odom_camera.inverse() * b.T_odom_camera;
    const double turn_deg = Eigen::AngleAxisd(motion.linear()).angle() * 180.0 / M_PI;
    const double sigma_m = options.odometry_sigma_m + options.odometry_sigma_per_m * motion.translation().norm();
    const double sigma_deg = options.odometry_sigma_deg + options.odometry_sigma_per_deg * turn_deg;
    problem->AddResidualBlock(new ceres::AutoDiffCostFunction<OdometryResidual, 6, 3, 3>(new OdometryResidual{
                                  &a.T_map_camera, &b.T_map_camera, motion, 1.0 / sigma_m, 180.0 / (M_PI * sigma_deg)}),
                              nullptr, (*pose)[k - 1].data(), (*pose)[k].data());
  }
}

ObservationResidual makeResidual(const Keyframe& kf, const KeyframeLine& o, const LineBasis& basis,
                                 const LineMapAdjustmentOptions& options)
{
  ObservationResidual r;
  r.tf = &kf.T_map_camera;
  r.basis = &basis;
  r.image_a = o.image_a.homogeneous();
  r.image_b = o.image_b.homogeneous();
  r.depth_a = o.line.a;
  r.depth_b = o.line.b;
  const Eigen::Vector3d dir = (o.line.b - o.line.a).normalized();
  const Eigen::Vector3d normal = o.line.a.cross(o.line.b).normalized();
  r.depth_direction = normal.cross(dir).normalized();
  r.focal_over_sigma_px = kf.focal_px / options.rgb_sigma_px;
  // The registration's share (sigma_systematic_m) too: the same in every keyframe, it must not pull their poses.
  r.inverse_sigma_depth = 1.0 / std::hypot(o.line.sigma_m, o.line.sigma_systematic_m, options.depth_floor_m);
  return r;
}

Status validate(const std::vector<Keyframe>& keyframes, const std::vector<AdjustedLine>& lines,
                const std::vector<LineObservation>& observations, const std::vector<PoseCorrection>& corrections,
                const LineMapAdjustmentOptions& o)
{
  if (observations.empty())
    return Error(ErrorCode::kNotEnoughData, "no observations of map lines to adjust");
  if (!corrections.empty() && corrections.size() != keyframes.size())
    return Error(ErrorCode::kInvalidInput, "one pose correction per keyframe (or none) expected");
  if (!(o.rgb_sigma_px > 0.0 && o.depth_floor_m > 0.0 && o.localization_sigma_m > 0.0 &&
        o.localization_sigma_deg > 0.0))
    return Error(ErrorCode::kInvalidInput, "the adjustment's sigmas must be positive");
  if (!(o.localization_correlation_s >= 0.0 && std::isfinite(o.localization_correlation_s)))
    return Error(ErrorCode::kInvalidInput, "the localiser's correlation time must be 0 or positive (seconds)");
  if (o.localization_correlation_s > 0.0)
    for (const auto& kf : keyframes)
      if (!std::isfinite(kf.stamp))
        return Error(ErrorCode::kInvalidInput,
                     "a keyframe without a finite stamp: the localiser's correlation needs every keyframe's time");
  for (const auto& ob : observations)
    if (ob.keyframe < 0 || ob.keyframe >= static_cast<int>(keyframes.size()) || ob.map_line < 0 ||
        ob.map_line >= static_cast<int>(lines.size()) || ob.line < 0 ||
        ob.line >= static_cast<int>(keyframes[ob.keyframe].lines.size()))
      return Error(ErrorCode::kInvalidInput, "an observation refers to a keyframe, line or map line that is not there");
  return Success{};
}

// Marginal standard deviations of the poses and lines (those in the problem), from Ceres' covariance.
void addCovariance(ceres::Problem* problem, std::vector<Eigen::Vector3d>* pose, std::vector<Eigen::Vector4d>* line,
                   LineMapAdjustmentResult* result)
{
  ceres::Covariance::Options options;
  options.algorithm_type = ceres::SPARSE_QR;
  options.num_threads = 1;
  ceres::Covariance covariance(options);
  std::vector<std::pair<const double*, const double*>> blocks;
  for (auto& p : *pose)
    blocks.emplace_back(p.data(), p.data());
  for (auto& l : *line)
    if (problem->HasParameterBlock(l.data()))
      blocks.emplace_back(l.data(), l.data());
  if (!covariance.Compute(blocks, problem))
    return;
  for (auto& p : *pose)
  {
    Eigen::Matrix3d c;
    covariance.GetCovarianceBlock(p.data(), p.data(), c.data());
    result->pose_sigmas.push_back(c.diagonal().cwiseMax(0.0).cwiseSqrt());
  }
  for (auto& l : *line)
  {
    Eigen::Matrix4d c = Eigen::Matrix4d::Zero();
    if (problem->HasParameterBlock(l.data()))
      covariance.GetCovarianceBlock(l.data(), l.data(), c.data());
    const double position = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(c.topLeftCorner<2, 2>()).eigenvalues()(1);
    const double direction =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(c.bottomRightCorner<2, 2>()).eigenvalues()(1);
    result->line_sigmas.emplace_back(std::sqrt(std::max(0.0, position)), std::sqrt(std::max(0.0, direction)));
  }
}

// The lines are eliminated; the keyframes' reduced system is dense where lines are seen from many keyframes, so
// factorising it costs the cube of their number (a 5 min survey's 860 keyframes: 40 of its 50 s). Conjugate
// gradients on it grow about linearly.
bool iterativeSteps(const LineMapAdjustmentOptions& options, size_t keyframes)
{
  return options.iterative_above_keyframes > 0 && keyframes > options.iterative_above_keyframes;
}

double solve(ceres::Problem* problem, const LineMapAdjustmentOptions& adjustment, size_t keyframes,
             double* initial_cost)
{
  ceres::Solver::Options options;
  if (iterativeSteps(adjustment, keyframes))
  {
    options.linear_solver_type = ceres::ITERATIVE_SCHUR;
    options.preconditioner_type = ceres::SCHUR_JACOBI;
  }
  else
    options.linear_solver_type = ceres::SPARSE_SCHUR;
  options.max_num_iterations = adjustment.max_iterations;
  options.num_threads = 1;
  options.function_tolerance = 1e-10;
  options.gradient_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(options, problem, &summary);
  if (initial_cost)
    *initial_cost = summary.initial_cost;
  return summary.final_cost;
}

// The keyframe's tf camera position in the floor's plane: the pivot of its correction.
Eigen::Vector2d pivot(const Keyframe& keyframe)
{
  return keyframe.T_map_camera.translation().head<2>();
}

// A rigid turn phi (about q) and shift t of the whole adjusted survey in the floor's plane. The observations and
// odometry do not see it: it moves a keyframe's correction (shift d about its pivot p, yaw) to
// R(phi) (p + d - q) + q + t - p and yaw + phi, and the map lines with the keyframes.
struct RigidPlacement
{
  double phi = 0.0;
  Eigen::Vector2d q = Eigen::Vector2d::Zero(), t = Eigen::Vector2d::Zero();
  Eigen::Vector2d move(const Eigen::Vector2d& x) const { return Eigen::Rotation2Dd(phi) * (x - q) + q + t; }
  PoseCorrection correction(const Eigen::Vector2d& p, const Eigen::Vector3d& pose) const
  {
    const Eigen::Vector2d d = move(p + pose.head<2>()) - p;
    return {d.x(), d.y(), pose.z() + phi};
  }
  AdjustedLine line(AdjustedLine l) const
  {
    l.point.head<2>() = move(l.point.head<2>()).eval();
    l.direction = Eigen::AngleAxisd(phi, Eigen::Vector3d::UnitZ()) * l.direction;
    return l;
  }
};

// The rigid motion of the adjusted survey that brings it closest to the tf poses, every keyframe weighed alike by the
// localiser's sigmas (sum of |d_k|^2 / sigma_m^2 + yaw_k^2 / sigma_rad^2): where independent priors place a survey,
// at the localiser's average over the keyframes. With q the pivots' mean, b_k = p_k - q and a_k = p_k + d_k - q about
// their mean: the best t makes the shifts' mean zero, and phi minimises
// J(phi) = -2 (cos phi S_c + sin phi S_s) / sigma_m^2 + n (phi + mean yaw)^2 / sigma_rad^2 (Newton).
RigidPlacement placementAtTheLocalisersMean(const std::vector<Keyframe>& keyframes,
                                            const std::vector<Eigen::Vector3d>& pose,
                                            const LineMapAdjustmentOptions& options)
{
  const double n = static_cast<double>(keyframes.size());
  RigidPlacement g;
  for (const auto& kf : keyframes)
    g.q += pivot(kf) / n;
  Eigen::Vector2d mean_a = Eigen::Vector2d::Zero();
  double mean_yaw = 0.0;
  for (size_t k = 0; k < keyframes.size(); ++k)
  {
    mean_a += (pivot(keyframes[k]) + pose[k].head<2>() - g.q) / n;
    mean_yaw += pose[k].z() / n;
  }
  double s_c = 0.0, s_s = 0.0;
  for (size_t k = 0; k < keyframes.size(); ++k)
  {
    const Eigen::Vector2d b = pivot(keyframes[k]) - g.q;
    const Eigen::Vector2d a = pivot(keyframes[k]) + pose[k].head<2>() - g.q - mean_a;
    s_c += b.dot(a);
    s_s += b.y() * a.x() - b.x() * a.y();
  }
  const double w_m = 1.0 / (options.localization_sigma_m * options.localization_sigma_m);
  const double sigma_rad = options.localization_sigma_deg * M_PI / 180.0, w_rad = 1.0 / (sigma_rad * sigma_rad);
  double phi = -mean_yaw;
  for (int i = 0; i < 20; ++i)
  {
    const double c = std::cos(phi), s = std::sin(phi);
    const double gradient = -2.0 * w_m * (-s * s_c + c * s_s) + 2.0 * w_rad * n * (phi + mean_yaw);
    const double curvature = std::max(2.0 * w_m * (c * s_c + s * s_s) + 2.0 * w_rad * n, 1e-12);
    const double step = gradient / curvature;
    phi -= step;
    if (std::abs(step) < 1e-12)
      break;
  }
  g.phi = phi;
  g.t = -(Eigen::Rotation2Dd(phi) * mean_a);
  return g;
}

// Marks the observations with a residual beyond limit (in sigmas) as outliers; whether there were any.
bool anyOutlier(const std::vector<LineObservation>& observations, const std::vector<ObservationResidual>& residuals,
                const std::vector<Eigen::Vector3d>& pose, const std::vector<Eigen::Vector4d>& line, double limit,
                LineMapAdjustmentResult* result)
{
  for (size_t i = 0; i < observations.size(); ++i)
  {
    double r[4];
    residuals[i](pose[observations[i].keyframe].data(), line[observations[i].map_line].data(), r);
    if (Eigen::Map<Eigen::Vector4d>(r).cwiseAbs().maxCoeff() > limit)
    {
      result->inlier[i] = false;
      ++result->dropped;
    }
  }
  return result->dropped > 0;
}
}  // namespace

Eigen::Isometry3d PoseCorrection::apply(const Eigen::Isometry3d& T_map_camera) const
{
  Eigen::Isometry3d out = T_map_camera;
  out.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * T_map_camera.linear();
  out.translation() += Eigen::Vector3d(x, y, 0.0);
  return out;
}

Expected<LineMapAdjustmentResult> adjustLineMap(const std::vector<Keyframe>& keyframes,
                                                const std::vector<AdjustedLine>& lines,
                                                const std::vector<LineObservation>& observations,
                                                const std::vector<PoseCorrection>& corrections,
                                                const LineMapAdjustmentOptions& options)
{
  if (const Status valid = validate(keyframes, lines, observations, corrections, options); !valid)
    return valid.error();
  const double start = threadCpuMs();
  std::vector<LineBasis> bases;
  for (const auto& l : lines)
    bases.emplace_back(l);
  std::vector<Eigen::Vector3d> pose(keyframes.size(), Eigen::Vector3d::Zero());
  for (size_t k = 0; k < corrections.size(); ++k)
    pose[k] = {corrections[k].x, corrections[k].y, corrections[k].yaw};
  std::vector<Eigen::Vector4d> line(lines.size(), Eigen::Vector4d::Zero());
  std::vector<ObservationResidual> residuals;
  for (const auto& ob : observations)
    residuals.push_back(
        makeResidual(keyframes[ob.keyframe], keyframes[ob.keyframe].lines[ob.line], bases[ob.map_line], options));

  LineMapAdjustmentResult result;
  result.inlier.assign(observations.size(), true);
  result.iterative = iterativeSteps(options, keyframes.size());
  // Round 0 with every observation (robust loss), round 1 without the outliers it finds.
  for (int round = 0; round < 2; ++round)
  {
    ceres::Problem problem;
    addLocalizationPriors(keyframes, options, &pose, &problem);
    addOdometry(keyframes, options, &pose, &problem);
    for (size_t i = 0; i < observations.size(); ++i)
      if (result.inlier[i])
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<ObservationResidual, 4, 3, 4>(new ObservationResidual(residuals[i])),
            new ceres::CauchyLoss(options.loss_sigmas), pose[observations[i].keyframe].data(),
            line[observations[i].map_line].data());
    const double final_cost = solve(&problem, options, keyframes.size(), round == 0 ? &result.initial_cost : nullptr);
    result.final_cost = final_cost;
    if (round == 1 || !anyOutlier(observations, residuals, pose, line, options.outlier_sigmas, &result))
    {
      if (options.covariance)
        addCovariance(&problem, &pose, &line, &result);
      break;
    }
  }

  // The chain gives the survey's shape; its own placement weighs the chain's ends most, so the survey is moved to
  // where independent priors place it: the localiser's average over the keyframes, as the survey's limit is defined.
  const bool chained = options.localization_correlation_s > 0.0;
  const RigidPlacement g = chained ? placementAtTheLocalisersMean(keyframes, pose, options) : RigidPlacement{};
  for (size_t k = 0; k < pose.size(); ++k)
    result.corrections.push_back(chained ? g.correction(pivot(keyframes[k]), pose[k])
                                         : PoseCorrection{pose[k].x(), pose[k].y(), pose[k].z()});
  // Lines no inlier observed were not in the problem: returned as they came.
  std::vector<bool> observed(lines.size(), false);
  for (size_t i = 0; i < observations.size(); ++i)
    if (result.inlier[i])
      observed[observations[i].map_line] = true;
  for (size_t j = 0; j < lines.size(); ++j)
  {
    const AdjustedLine l = bases[j].adjusted(line[j].data());
    result.lines.push_back(chained && observed[j] ? g.line(l) : l);
  }
  result.cpu_ms = cpuMsSince(start);
  return result;
}

}  // namespace insitu_calibration

namespace insitu_calibration
{
Line3d lineInMap(const Keyframe& keyframe, const KeyframeLine& line, const PoseCorrection& correction)
{
  const Eigen::Isometry3d T = correction.apply(keyframe.T_map_camera);
  Line3d out = line.line;
  out.transform(T);
  out.sensor = T.translation();
  return out;
}

LineMap rebuildLineMap(const std::vector<Keyframe>& keyframes, const std::vector<PoseCorrection>& corrections,
                       const LineMapOptions& options)
{
  LineMap map(options);
  for (size_t k = 0; k < keyframes.size(); ++k)
    for (const auto& l : keyframes[k].lines)
      map.insert(lineInMap(keyframes[k], l, k < corrections.size() ? corrections[k] : PoseCorrection()));
  return map;
}

SurfaceVoxels rebuildSurfaces(const std::vector<Keyframe>& keyframes, const std::vector<PoseCorrection>& corrections,
                              const SurfaceVoxelOptions& options)
{
  SurfaceVoxels surfaces(options);
  for (size_t k = 0; k < keyframes.size(); ++k)
    surfaces.insertSamples(
        (k < corrections.size() ? corrections[k] : PoseCorrection()).apply(keyframes[k].T_map_camera),
        keyframes[k].surface);
  return surfaces;
}

namespace
{
// How far the observation o is from the map line (its larger end-point offset), or a negative value when it is not
// compatible with it.
double compatibleDistance(const Line3d& o, const MapLine& line, const LineMapOptions& options)
{
  const Eigen::Vector3d dir = o.direction();
  if (std::abs(dir.dot(line.direction)) < std::cos(options.max_angle_deg * M_PI / 180.0))
    return -1.0;
  const Eigen::Vector3d normal = (o.a - o.sensor).cross(o.b - o.sensor).normalized();
  const Eigen::Vector3d in_plane = normal.cross(dir).normalized();
  const double range = std::max(0.0, o.range_m);
  const double lateral_limit = options.max_lateral_m + options.max_lateral_per_m * range;
  const double depth_limit = options.depth_sigmas * std::hypot(o.sigma_m, options.depth_floor_m);
  double worst = 0.0;
  for (const Eigen::Vector3d& p : {o.a, o.b})
  {
    const Eigen::Vector3d r = p - line.point;
    const Eigen::Vector3d offset = r - r.dot(line.direction) * line.direction;
    if (std::abs(offset.dot(normal)) > lateral_limit || std::abs(offset.dot(in_plane)) > depth_limit)
      return -1.0;
    worst = std::max(worst, offset.norm());
  }
  const double sa = (o.a - line.point).dot(line.direction), sb = (o.b - line.point).dot(line.direction);
  const double gap = std::max({0.0, std::min(sa, sb) - line.s_max, line.s_min - std::max(sa, sb)});
  return gap > options.max_gap_m ? -1.0 : worst;
}
}  // namespace

std::vector<LineObservation> associateObservations(const std::vector<Keyframe>& keyframes,
                                                   const std::vector<PoseCorrection>& corrections,
                                                   const std::vector<MapLine>& lines, const LineMapOptions& options)
{
  std::vector<LineObservation> out;
  for (size_t k = 0; k < keyframes.size(); ++k)
    for (size_t i = 0; i < keyframes[k].lines.size(); ++i)
    {
      const Line3d o =
          lineInMap(keyframes[k], keyframes[k].lines[i], k < corrections.size() ? corrections[k] : PoseCorrection());
      int best = -1;
      double best_distance = std::numeric_limits<double>::infinity();
      for (size_t j = 0; j < lines.size(); ++j)
      {
        const double d = compatibleDistance(o, lines[j], options);
        if (d >= 0.0 && d < best_distance)
        {
          best = static_cast<int>(j);
          best_distance = d;
        }
      }
      if (best >= 0)
        out.push_back({static_cast<int>(k), static_cast<int>(i), best});
    }
  return out;
}

}  // namespace insitu_calibration
