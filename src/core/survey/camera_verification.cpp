#include "insitu_calibration/survey/camera_verification.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Dense>

#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/robust_statistics.h"

namespace insitu_calibration
{
namespace
{
constexpr double kRadToDeg = 180.0 / M_PI;
using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// A matched image line as the fit uses it: the end points of the straight line through its undistorted points
// (two measurements per line, so that a long line does not outweigh the others by its number of points) and the
// map line's end points.
struct LineMeasurement
{
  Eigen::Vector2d first;
  Eigen::Vector2d last;
  Segment3d map_line;
};

std::optional<LineMeasurement> measurementOf(const DivisionModel& distortion,
                                             const std::vector<Eigen::Vector2d>& image_line, const Segment3d& map_line)
{
  std::vector<Eigen::Vector2d> points;
  for (const auto& p : image_line)
    if (const auto u = distortion.undistort(p))
      points.push_back(*u);
  if (points.size() < 2)
    return std::nullopt;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points)
    mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const auto& p : points)
    scatter += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(scatter);
  const Eigen::Vector2d direction = eigen.eigenvectors().col(1);
  LineMeasurement m;
  m.first = mean + direction * direction.dot(points.front() - mean);
  m.last = mean + direction * direction.dot(points.back() - mean);
  m.map_line = map_line;
  return m;
}

// The pose change applied to a camera-frame point: rotation (angle-axis) then translation.
template <typename T>
void movePoint(const T* const delta, const Eigen::Vector3d& camera_point, T* moved)
{
  const T p[3] = {T(camera_point.x()), T(camera_point.y()), T(camera_point.z())};
  ceres::AngleAxisRotatePoint(delta, p, moved);
  for (int i = 0; i < 3; ++i)
    moved[i] += delta[3 + i];
}

// Signed distance (px) of a measured end point to the map line projected by the moved camera (undistorted pixels).
struct LineEndResidual
{
  LineEndResidual(const Intrinsics& k, const Eigen::Vector3d& a_camera, const Eigen::Vector3d& b_camera,
                  const Eigen::Vector2d& point)
      : k_(k), a_(a_camera), b_(b_camera), point_(point)
  {}

  template <typename T>
  bool operator()(const T* const delta, T* residual) const
  {
    T a[3], b[3];
    movePoint(delta, a_, a);
    movePoint(delta, b_, b);
    // Normalised image coordinates -> pixels is affine: the line through the two projected pixels.
    const T ax = T(k_.fx) * a[0] / a[2] + T(k_.skew) * a[1] / a[2] + T(k_.cx), ay = T(k_.fy) * a[1] / a[2] + T(k_.cy);
    const T bx = T(k_.fx) * b[0] / b[2] + T(k_.skew) * b[1] / b[2] + T(k_.cx), by = T(k_.fy) * b[1] / b[2] + T(k_.cy);
    const T dx = bx - ax, dy = by - ay;
    const T length = ceres::sqrt(dx * dx + dy * dy);
    residual[0] = (dx * (T(point_.y()) - ay) - dy * (T(point_.x()) - ax)) / length;
    return true;
  }

  Intrinsics k_;
  Eigen::Vector3d a_, b_;
  Eigen::Vector2d point_;
};

// Fits the pose change to the measurements (Huber loss when robust_scale_px > 0); returns the residuals, two per
// measurement.
std::vector<double> fitPoseChange(const CameraModel& calibrated, const std::vector<LineMeasurement>& measurements,
                                  double robust_scale_px, bool rotation_only, Vector6d* delta)
{
  ceres::Problem problem;
  for (const auto& m : measurements)
  {
    const Eigen::Vector3d a = calibrated.toCamera(m.map_line.a), b = calibrated.toCamera(m.map_line.b);
    for (const Eigen::Vector2d& point : {m.first, m.last})
    {
      auto* cost = new ceres::AutoDiffCostFunction<LineEndResidual, 1, 6>(
          new LineEndResidual(calibrated.intrinsics(), a, b, point));
      problem.AddResidualBlock(cost, robust_scale_px > 0.0 ? new ceres::HuberLoss(robust_scale_px) : nullptr,
                               delta->data());
    }
  }
  if (rotation_only && problem.NumResidualBlocks() > 0)
    problem.SetManifold(delta->data(), new ceres::SubsetManifold(6, {3, 4, 5}));
  ceres::Solver::Options options;
  options.max_num_iterations = 50;
  options.linear_solver_type = ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  std::vector<double> residuals;
  ceres::Problem::EvaluateOptions evaluate;
  evaluate.apply_loss_function = false;
  problem.Evaluate(evaluate, nullptr, &residuals, nullptr, nullptr);
  return residuals;
}

// The Jacobian of the residuals at the fitted change (for the covariance), by the same cost functions.
Eigen::MatrixXd residualJacobian(const CameraModel& calibrated, const std::vector<LineMeasurement>& measurements,
                                 const Vector6d& delta)
{
  Eigen::MatrixXd jacobian(2 * measurements.size(), 6);
  int row = 0;
  for (const auto& m : measurements)
  {
    const Eigen::Vector3d a = calibrated.toCamera(m.map_line.a), b = calibrated.toCamera(m.map_line.b);
    for (const Eigen::Vector2d& point : {m.first, m.last})
    {
      ceres::AutoDiffCostFunction<LineEndResidual, 1, 6> cost(
          new LineEndResidual(calibrated.intrinsics(), a, b, point));
      double residual = 0.0;
      double j[6];
      double* jacobians[1] = {j};
      const double* parameters[1] = {delta.data()};
      cost.Evaluate(parameters, &residual, jacobians);
      for (int c = 0; c < 6; ++c)
        jacobian(row, c) = j[c];
      ++row;
    }
  }
  return jacobian;
}

CameraPose movedPose(const CameraPose& pose, const Vector6d& delta)
{
  const Eigen::Vector3d w = delta.head<3>();
  const Eigen::Matrix3d r =
      w.norm() > 0.0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
  CameraPose moved;
  moved.rotation = r * pose.rotation;
  moved.translation = r * pose.translation + delta.tail<3>();
  return moved;
}

// Per world point the undistorted projection by the moved camera, stacked (2 rows per point).
Eigen::VectorXd projections(const CameraModel& calibrated, const Vector6d& delta,
                            const std::vector<Eigen::Vector3d>& points)
{
  const CameraModel moved(calibrated.intrinsics(), calibrated.distortion(), movedPose(calibrated.pose(), delta));
  Eigen::VectorXd out(2 * points.size());
  for (size_t i = 0; i < points.size(); ++i)
  {
    const Eigen::Vector3d c = moved.toCamera(points[i]);
    const Eigen::Vector3d m = calibrated.intrinsics().matrix() * c / c.z();
    out.segment<2>(2 * i) = m.head<2>();
  }
  return out;
}

struct MatchedLines
{
  std::vector<LineMeasurement> measurements;
  std::vector<Segment3d> map_lines;
};

MatchedLines matchUnder(const CameraModel& calibrated, const Vector6d& delta, int width, int height,
                        const std::vector<Segment3d>& map_lines,
                        const std::vector<std::vector<Eigen::Vector2d>>& image_lines, double max_distance_px,
                        const CameraVerificationOptions& options)
{
  const CameraModel moved(calibrated.intrinsics(), calibrated.distortion(), movedPose(calibrated.pose(), delta));
  MatchedLines matched;
  for (const LineMatch& m : matchLines(map_lines, image_lines, moved, width, height, options.max_angle_deg,
                                       max_distance_px, options.matcher))
    if (const auto measurement =
            measurementOf(calibrated.distortion(), image_lines[m.image_line], map_lines[m.map_line]))
    {
      matched.measurements.push_back(*measurement);
      matched.map_lines.push_back(map_lines[m.map_line]);
    }
  return matched;
}

// The rotation on a grid (tilt, pan and roll about the calibrated camera's x, y, z axes, within search_range_deg)
// under which the image lines are best explained: per matched line 1 - distance / search_distance_px, summed. The
// grid step keeps every motion within the range a fraction of the threshold from a grid point. Against a map that
// holds few of the image's lines, the nearest line after a large shift is often another one: a fit started at zero
// from such matches can settle on a wrong pose (tilt traded for a translation of decimetres).
Vector6d coarseRotation(const CameraModel& calibrated, int width, int height, const std::vector<Segment3d>& map_lines,
                        const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                        const CameraVerificationOptions& options)
{
  const double step = options.search_step_deg * M_PI / 180.0;
  const int n = static_cast<int>(std::ceil(options.search_range_deg / options.search_step_deg));
  Vector6d best = Vector6d::Zero();
  double best_score = -1.0;
  for (int roll = -n; roll <= n; roll += 2)  // a roll moves the image less than a pan: half the grid
    for (int tilt = -n; tilt <= n; ++tilt)
      for (int pan = -n; pan <= n; ++pan)
      {
        Vector6d delta = Vector6d::Zero();
        delta.head<3>() = step * Eigen::Vector3d(tilt, pan, roll);
        const CameraModel moved(calibrated.intrinsics(), calibrated.distortion(), movedPose(calibrated.pose(), delta));
        double score = 0.0;
        for (const LineMatch& m : matchLines(map_lines, image_lines, moved, width, height, options.max_angle_deg,
                                             options.search_distance_px, options.matcher))
          score += 1.0 - m.distance_px / options.search_distance_px;
        // Ties (a featureless view) go to the smaller motion.
        if (score > best_score + 1e-9 || (std::abs(score - best_score) <= 1e-9 && delta.norm() < best.norm()))
        {
          best_score = score;
          best = delta;
        }
      }
  return best;
}

// The fitted change and its covariance from the inliers of a robust fit (residuals within 3 robust sigmas, at
// least robust_scale_px), refitted by plain least squares; the covariance is scaled by the inliers' variance.
struct PoseFit
{
  Vector6d delta = Vector6d::Zero();
  Matrix6d covariance = Matrix6d::Zero();
  double rms_px = 0.0;
  bool ok = false;
};

PoseFit fitWithCovariance(const CameraModel& calibrated, const std::vector<LineMeasurement>& measurements,
                          const Vector6d& start, double robust_scale_px, bool rotation_only)
{
  PoseFit fit;
  fit.delta = start;
  const std::vector<double> robust =
      fitPoseChange(calibrated, measurements, robust_scale_px, rotation_only, &fit.delta);
  std::vector<double> absolute;
  for (double r : robust)
    absolute.push_back(std::abs(r));
  const double limit = std::max(robust_scale_px, 3.0 * robustSigma(absolute));
  std::vector<LineMeasurement> inliers;
  for (size_t i = 0; i < measurements.size(); ++i)
    if (absolute[2 * i] <= limit && absolute[2 * i + 1] <= limit)
      inliers.push_back(measurements[i]);
  if (inliers.size() < 4)
    return fit;
  const std::vector<double> residuals = fitPoseChange(calibrated, inliers, 0.0, rotation_only, &fit.delta);
  double sum2 = 0.0;
  for (double r : residuals)
    sum2 += r * r;
  const double dof = static_cast<double>(residuals.size()) - 6.0;
  fit.rms_px = std::sqrt(sum2 / static_cast<double>(residuals.size()));
  const Eigen::MatrixXd j = residualJacobian(calibrated, inliers, fit.delta);
  const Matrix6d information = j.transpose() * j;
  fit.covariance = (sum2 / dof) * information.inverse();
  fit.ok = dof > 0.0 && fit.covariance.allFinite();
  return fit;
}

// The magnitudes of the fitted change and their sigmas: by the delta method along the change, and at least what the
// noise alone gives (the RMS magnitude of a zero change measured with this covariance).
void describeMagnitudes(const CameraModel& calibrated, const PoseFit& fit, const std::vector<Eigen::Vector3d>& points,
                        CameraMotion* motion)
{
  const Eigen::VectorXd base = projections(calibrated, Vector6d::Zero(), points);
  const Eigen::VectorXd now = projections(calibrated, fit.delta, points);
  const double n = static_cast<double>(points.size());
  motion->displacement_px = std::sqrt((now - base).squaredNorm() / n);
  Eigen::MatrixXd jacobian(now.size(), 6);  // of the projections, numerically
  for (int c = 0; c < 6; ++c)
  {
    Vector6d step = Vector6d::Zero();
    step(c) = 1e-7;
    jacobian.col(c) =
        (projections(calibrated, fit.delta + step, points) - projections(calibrated, fit.delta - step, points)) / 2e-7;
  }
  const double noise_px = std::sqrt((jacobian * fit.covariance * jacobian.transpose()).trace() / n);
  double along_px = 0.0;
  if (motion->displacement_px > 0.0)
  {
    const Eigen::VectorXd gradient = jacobian.transpose() * (now - base) / (n * motion->displacement_px);
    along_px = std::sqrt(gradient.dot(fit.covariance * gradient));
  }
  motion->displacement_sigma_px = std::max(along_px, noise_px);
  const auto magnitude = [](const Eigen::Vector3d& v, const Eigen::Matrix3d& c, double* sigma) {
    const double along = v.norm() > 0.0 ? std::sqrt(v.normalized().dot(c * v.normalized())) : 0.0;
    *sigma = std::max(along, std::sqrt(c.trace()));
    return v.norm();
  };
  double rotation_sigma = 0.0;
  motion->rotation_deg =
      magnitude(fit.delta.head<3>(), fit.covariance.topLeftCorner<3, 3>(), &rotation_sigma) * kRadToDeg;
  motion->rotation_sigma_deg = rotation_sigma * kRadToDeg;
  motion->translation_m =
      magnitude(fit.delta.tail<3>(), fit.covariance.bottomRightCorner<3, 3>(), &motion->translation_sigma_m);
}

std::string formatMotion(const CameraMotion& m)
{
  char text[256];
  std::snprintf(text, sizeof(text), "%.2f +- %.2f px / %.3f +- %.3f deg (%.1f +- %.1f mm)", m.displacement_px,
                m.displacement_sigma_px, m.rotation_deg, m.rotation_sigma_deg, 1000.0 * m.translation_m,
                1000.0 * m.translation_sigma_m);
  return text;
}

void judge(const CameraVerificationOptions& options, CameraMotion* m)
{
  const double k = options.sigma_factor;
  const bool moved = m->displacement_px - k * m->displacement_sigma_px > options.max_displacement_px ||
                     m->rotation_deg - k * m->rotation_sigma_deg > options.max_rotation_deg;
  const bool unmoved = m->displacement_px + k * m->displacement_sigma_px <= options.max_displacement_px &&
                       m->rotation_deg + k * m->rotation_sigma_deg <= options.max_rotation_deg;
  char limits[128];
  std::snprintf(limits, sizeof(limits), "limits %.2f px / %.2f deg, %zu lines matched", options.max_displacement_px,
                options.max_rotation_deg, m->matched_lines);
  if (moved)
  {
    m->verdict = CameraMotionVerdict::kMoved;
    m->message = "camera moved by " + formatMotion(*m) + " since calibration: recalibrate (" + limits + ")";
  }
  else if (unmoved)
  {
    m->verdict = CameraMotionVerdict::kUnmoved;
    m->message = "camera unmoved since calibration: " + formatMotion(*m) + " (" + limits + ")";
  }
  else
  {
    m->verdict = CameraMotionVerdict::kUnknown;
    char sigmas[32];
    std::snprintf(sigmas, sizeof(sigmas), "%.1f", options.sigma_factor);
    m->message = "cannot tell whether the camera moved: " + formatMotion(*m) + " is within " + sigmas +
                 " sigma of the limits (" + limits + ")";
  }
}
}  // namespace

const char* toString(CameraMotionVerdict verdict)
{
  switch (verdict)
  {
    case CameraMotionVerdict::kUnmoved:
      return "unmoved";
    case CameraMotionVerdict::kMoved:
      return "moved";
    default:
      return "unknown";
  }
}

std::vector<Eigen::Vector3d> visibleMapPoints(const CameraModel& camera, int image_width, int image_height,
                                              const std::vector<Segment3d>& map_lines, int samples_per_line)
{
  std::vector<Eigen::Vector3d> points;
  for (const auto& line : map_lines)
    if (const auto interval = visibleInterval(camera, line, image_width, image_height))
      for (int i = 0; i < samples_per_line; ++i)
      {
        const double s = samples_per_line > 1 ? static_cast<double>(i) / (samples_per_line - 1) : 0.5;
        points.push_back(line.pointAt(interval->first + s * (interval->second - interval->first)));
      }
  return points;
}

PoseDifference poseDifference(const CameraModel& before, const CameraPose& after,
                              const std::vector<Eigen::Vector3d>& world_points)
{
  PoseDifference d;
  const Eigen::Matrix3d r = after.rotation * before.pose().rotation.transpose();
  d.rotation_deg = Eigen::AngleAxisd(r).angle() * kRadToDeg;
  d.translation_m = (after.center() - before.pose().center()).norm();
  const CameraModel moved(before.intrinsics(), before.distortion(), after);
  double sum2 = 0.0;
  size_t n = 0;
  for (const auto& x : world_points)
  {
    const auto a = before.projectUndistorted(x), b = moved.projectUndistorted(x);
    if (a && b)
    {
      sum2 += (*b - *a).squaredNorm();
      ++n;
    }
  }
  d.displacement_px = n > 0 ? std::sqrt(sum2 / static_cast<double>(n)) : 0.0;
  return d;
}

namespace
{
CameraMotion tooFewLines(size_t matched, const CameraVerificationOptions& options)
{
  CameraMotion motion;
  motion.matched_lines = matched;
  motion.message = "cannot verify the camera: only " + std::to_string(matched) + " image lines match the line map (" +
                   std::to_string(options.min_matched_lines) +
                   " needed); is the view blocked, dark, or has the camera moved far?";
  return motion;
}
}  // namespace

Expected<CameraMotion> verifyCameraPose(const CameraModel& calibrated, int image_width, int image_height,
                                        const std::vector<Segment3d>& map_lines,
                                        const std::vector<std::vector<Eigen::Vector2d>>& image_lines,
                                        const CameraVerificationOptions& options,
                                        const std::vector<double>& map_line_sigmas_m)
{
  if (image_width <= 0 || image_height <= 0)
    return Error(ErrorCode::kInvalidInput, "verifyCameraPose: the image size must be positive");
  if (map_lines.empty())
    return Error(ErrorCode::kNotEnoughData, "cannot verify the camera: the line map is empty");
  const std::vector<Segment3d> fitted = verificationMapLines(map_lines, map_line_sigmas_m, options);
  PoseFit fit;  // the last successful fit
  fit.delta = coarseRotation(calibrated, image_width, image_height, fitted, image_lines, options);
  MatchedLines used;  // its matches
  size_t last_matched = 0;
  double threshold_px = options.search_distance_px;
  for (int round = 0; round < options.max_rounds + options.rotation_only_rounds; ++round)
  {
    MatchedLines matched =
        matchUnder(calibrated, fit.delta, image_width, image_height, fitted, image_lines, threshold_px, options);
    last_matched = matched.measurements.size();
    if (last_matched < options.min_matched_lines)
      break;
    // The first round's matches may be off by the whole motion: a wide robust scale lets them pull.
    const double scale = round == 0 ? std::max(options.robust_scale_px, 0.25 * threshold_px) : options.robust_scale_px;
    // The first rounds fit a rotation only: it explains most of any small motion's shift with half the unknowns, so
    // that a few wrong matches of the wide first threshold cannot trade rotation for translation.
    const bool rotation_only = round < options.rotation_only_rounds;
    const PoseFit next_fit = fitWithCovariance(calibrated, matched.measurements, fit.delta, scale, rotation_only);
    if (!next_fit.ok)
      break;
    fit = next_fit;
    used = std::move(matched);
    const double next = std::max(options.min_distance_px, options.distance_factor * fit.rms_px);
    if (round > options.rotation_only_rounds && next >= threshold_px)
      break;  // the thresholds stopped tightening: the matches are final
    threshold_px = std::min(threshold_px, std::max(next, 0.5 * threshold_px));
  }
  if (!fit.ok)
    return tooFewLines(last_matched, options);
  CameraMotion motion;
  motion.image_lines = image_lines.size();
  motion.matched_lines = used.measurements.size();
  motion.rms_px = fit.rms_px;
  motion.covariance = fit.covariance;
  motion.rotation = movedPose(CameraPose{}, fit.delta).rotation;
  motion.translation = fit.delta.tail<3>();
  describeMagnitudes(calibrated, fit, visibleMapPoints(calibrated, image_width, image_height, map_lines), &motion);
  judge(options, &motion);
  return motion;
}
PoseDifference calibrationChange(const CalibrationFile& before, const CalibrationFile& after,
                                 const std::vector<Segment3d>& map_lines)
{
  std::vector<Eigen::Vector3d> points =
      visibleMapPoints(before.camera, before.image_width, before.image_height, map_lines);
  if (points.empty())
    for (const auto& corner : {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(before.image_width - 1.0, 0.0),
                               Eigen::Vector2d(0.0, before.image_height - 1.0),
                               Eigen::Vector2d(before.image_width - 1.0, before.image_height - 1.0)})
      if (const auto ray = before.camera.backProject(corner))
        points.push_back(before.camera.pose().worldFromCamera() * (5.0 / ray->z() * *ray));
  return poseDifference(before.camera, after.camera.pose(), points);
}

std::string describeChange(const PoseDifference& change)
{
  char text[160];
  std::snprintf(text, sizeof(text), "moved by %.2f px / %.3f deg / %.1f mm since the previous calibration",
                change.displacement_px, change.rotation_deg, 1000.0 * change.translation_m);
  return text;
}

std::vector<Segment3d> verificationMapLines(const std::vector<Segment3d>& map_lines,
                                            const std::vector<double>& map_line_sigmas_m,
                                            const CameraVerificationOptions& options)
{
  if (options.max_map_line_sigma_m <= 0.0 || map_line_sigmas_m.size() != map_lines.size())
    return map_lines;
  std::vector<Segment3d> precise;
  for (size_t i = 0; i < map_lines.size(); ++i)
    if (map_line_sigmas_m[i] <= options.max_map_line_sigma_m)
      precise.push_back(map_lines[i]);
  return precise;
}

}  // namespace insitu_calibration
