#include "insitu_calibration/solvers/vertical_lines_focal_pose.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>

#include <Eigen/Dense>
#include <Eigen/Geometry>

namespace insitu_calibration
{
namespace
{
constexpr double kDegToRad = M_PI / 180.0;

// The lines in image coordinates centred on the principal point and divided by the image width (all values O(1)),
// the 3D lines as point and unit direction.
struct NormalizedLines
{
  std::array<Eigen::Vector3d, 4> image;  // homogeneous lines, (l1, l2) unit
  std::array<Eigen::Vector3d, 4> point;
  std::array<Eigen::Vector3d, 4> direction;
  Eigen::Vector3d vanishing;  // the vertical vanishing point: image[0] x image[1]
  size_t count = 4;           // lines used (3: the known-focal solver)
};

bool normalizeLines(const ImageMapLine* lines, size_t count, const Eigen::Vector2d& pp, double scale,
                    double vertical_tolerance_deg, NormalizedLines* out)
{
  const double cos_tolerance = std::cos(vertical_tolerance_deg * kDegToRad);
  out->count = count;
  for (size_t i = 0; i < count; ++i)
  {
    const Eigen::Vector2d a = (lines[i].image_a - pp) / scale;
    const Eigen::Vector2d b = (lines[i].image_b - pp) / scale;
    Eigen::Vector3d l = a.homogeneous().cross(b.homogeneous());
    const Eigen::Vector3d d = lines[i].world.b - lines[i].world.a;
    if (l.head<2>().norm() < 1e-12 || d.norm() < 1e-12)
      return false;
    out->image[i] = l / l.head<2>().norm();
    out->point[i] = lines[i].world.a;
    out->direction[i] = d.normalized();
    const bool vertical = std::abs(out->direction[i].z()) > cos_tolerance;
    if (vertical != (i < 2))
      return false;
  }
  out->vanishing = out->image[0].cross(out->image[1]);
  // The vertical pair must be two different image lines, and the up direction must have an image-y component (the
  // sign of "up" is decided by it).
  return out->vanishing.norm() > 1e-9 && std::abs(out->vanishing.y()) > 1e-9 * out->vanishing.norm();
}

// The plane through the camera centre and image line l, for the (normalised) focal length f: unit normal K^T l.
Eigen::Vector3d planeNormal(const Eigen::Vector3d& l, double f)
{
  return Eigen::Vector3d(f * l.x(), f * l.y(), l.z()).normalized();
}

// World up in the camera frame for focal f: K^-1 v, signed to point to the top of the image (-y).
Eigen::Vector3d upAxis(const Eigen::Vector3d& v, double f)
{
  Eigen::Vector3d u(v.x() / f, v.y() / f, v.z());
  u.normalize();
  return u.y() < 0.0 ? u : -u;
}

// For focal f: the rotation taking world z to up, and the yaw equations a cos + b sin + c = 0 of lines 2 and 3.
struct YawSystem
{
  Eigen::Matrix3d tilt;  // R_u: world z -> up
  double a[2], b[2], c[2];
  double det() const { return a[0] * b[1] - a[1] * b[0]; }
  double cosNumerator() const { return -c[0] * b[1] + c[1] * b[0]; }
  double sinNumerator() const { return -a[0] * c[1] + a[1] * c[0]; }
  // The equation in f: zero where the two lines' equations have a common yaw (their 2x2 system's solution
  // (cos, sin) has unit norm, multiplied by det^2). Line 3's residual on either yaw of line 2 would be a signed
  // alternative, but its two branches end and swap where line 2 admits one yaw only.
  double residual() const { return cosNumerator() * cosNumerator() + sinNumerator() * sinNumerator() - det() * det(); }
  double equation(int k, double yaw) const { return a[k] * std::cos(yaw) + b[k] * std::sin(yaw) + c[k]; }
  // The yaws satisfying both lines' equations within tolerance: each line's (up to two) solutions tried.
  std::vector<double> commonYaws(double tolerance) const
  {
    std::vector<double> yaws;
    for (int k = 0; k < 2; ++k)
    {
      const double r = std::hypot(a[k], b[k]);
      if (r < 1e-12)
        continue;
      const double q = std::clamp(-c[k] / r, -1.0, 1.0);
      for (int branch : {-1, 1})
      {
        const double yaw = std::atan2(b[k], a[k]) + branch * std::acos(q);
        const bool known = std::any_of(yaws.begin(), yaws.end(),
                                       [&](double y) { return std::abs(std::remainder(y - yaw, 2.0 * M_PI)) < 1e-6; });
        if (!known && std::abs(equation(0, yaw)) < tolerance && std::abs(equation(1, yaw)) < tolerance)
          yaws.push_back(yaw);
      }
    }
    return yaws;
  }
};

YawSystem yawSystem(const NormalizedLines& lines, double f)
{
  YawSystem s;
  s.tilt = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), upAxis(lines.vanishing, f)).toRotationMatrix();
  for (int k = 0; k < 2; ++k)
  {
    if (2 + k >= static_cast<int>(lines.count))
    {
      s.a[k] = s.b[k] = s.c[k] = 0.0;
      continue;
    }
    const Eigen::Vector3d m = s.tilt.transpose() * planeNormal(lines.image[2 + k], f);
    const Eigen::Vector3d& d = lines.direction[2 + k];
    s.a[k] = m.x() * d.x() + m.y() * d.y();
    s.b[k] = m.y() * d.x() - m.x() * d.y();
    s.c[k] = m.z() * d.z();
  }
  return s;
}

// A sign change of g in [x0, x1] bisected.
double bisect(const std::function<double(double)>& g, double x0, double x1)
{
  double g0 = g(x0);
  for (int it = 0; it < 60; ++it)
  {
    const double m = 0.5 * (x0 + x1);
    const double gm = g(m);
    if ((gm < 0.0) == (g0 < 0.0))
      x0 = m, g0 = gm;
    else
      x1 = m;
  }
  return 0.5 * (x0 + x1);
}

// The minimum of sign * g in [x0, x1] (golden section): where g comes closest to zero, or beyond it, between two
// samples of the same sign.
double extremum(const std::function<double(double)>& g, double sign, double x0, double x1)
{
  const double ratio = 0.5 * (std::sqrt(5.0) - 1.0);
  double c = x1 - ratio * (x1 - x0), d = x0 + ratio * (x1 - x0);
  double gc = sign * g(c), gd = sign * g(d);
  for (int it = 0; it < 80; ++it)
  {
    if (gc < gd)
      x1 = d, d = c, gd = gc, c = x1 - ratio * (x1 - x0), gc = sign * g(c);
    else
      x0 = c, c = d, gc = gd, d = x0 + ratio * (x1 - x0), gd = sign * g(d);
  }
  return 0.5 * (x0 + x1);
}

// Between samples k - 1 and k + 1 of one sign around a sample nearer zero: two roots closer than the sampling (g
// crosses zero and back: both bisected) or a double root (g touches zero). Lines 2 and 3 horizontal make c = 0 and
// g = -det^2: the root is then where det changes sign (bisected: the extremum of a flat g is found less precisely).
void rootsNearExtremum(const std::function<double(double)>& g, const std::function<double(double)>& det, double x0,
                       double x1, double sign, std::vector<double>* roots)
{
  const double xe = extremum(g, sign, x0, x1);
  if (sign * g(xe) < 0.0)
  {
    roots->push_back(bisect(g, x0, xe));
    roots->push_back(bisect(g, xe, x1));
  }
  else if (det(x0) * det(x1) < 0.0)
    roots->push_back(bisect(det, x0, x1));
  else
    roots->push_back(xe);  // validated by the caller (the lines' residuals)
}

// Roots of the equation in f (log-spaced samples): sign changes bisected, and local minima of |g| examined
// (rootsNearExtremum).
std::vector<double> focalRoots(const NormalizedLines& lines, double f_min, double f_max, int samples)
{
  const auto g = [&](double log_f) { return yawSystem(lines, std::exp(log_f)).residual(); };
  const auto det = [&](double log_f) { return yawSystem(lines, std::exp(log_f)).det(); };
  const double lo = std::log(f_min), hi = std::log(f_max);
  std::vector<double> x(samples + 1), gx(samples + 1);
  double largest = 0.0;
  for (int k = 0; k <= samples; ++k)
  {
    x[k] = lo + (hi - lo) * k / samples;
    gx[k] = g(x[k]);
    largest = std::max(largest, std::abs(gx[k]));
  }
  // An equation that vanishes everywhere (f not determined by the lines: e.g. the non-vertical pair parallel and
  // horizontal and the vertical vanishing point at infinity) has only rounding-noise roots.
  if (largest < 1e-9)
    return {};
  std::vector<double> roots;
  for (int k = 0; k < samples; ++k)
  {
    if (gx[k] == 0.0 || gx[k] * gx[k + 1] < 0.0)
      roots.push_back(gx[k] == 0.0 ? x[k] : bisect(g, x[k], x[k + 1]));
    const bool local_minimum = k > 0 && std::abs(gx[k]) <= std::abs(gx[k - 1]) &&
                               std::abs(gx[k]) <= std::abs(gx[k + 1]) && gx[k - 1] * gx[k] > 0.0 &&
                               gx[k] * gx[k + 1] > 0.0;
    if (local_minimum)
      rootsNearExtremum(g, det, x[k - 1], x[k + 1], gx[k] < 0.0 ? -1.0 : 1.0, &roots);
  }
  for (double& r : roots)
    r = std::exp(r);
  return roots.size() > 16 ? std::vector<double>{} : roots;  // rounding noise again
}

struct FocalYaw
{
  double f, yaw;
};

// The camera for a root (f in normalised units), if the lines determine it and it explains all four, in front.
std::optional<CameraPose> poseAt(const NormalizedLines& lines, const FocalYaw& root, double max_residual)
{
  const double f = root.f;
  const Eigen::Matrix3d r =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), upAxis(lines.vanishing, f)).toRotationMatrix() *
      Eigen::AngleAxisd(root.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const int n = static_cast<int>(lines.count);
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  std::array<Eigen::Vector3d, 4> normals;
  for (int i = 0; i < n; ++i)
  {
    normals[i] = planeNormal(lines.image[i], f);
    a.row(i) = normals[i].transpose();
    b(i) = -normals[i].dot(r * lines.point[i]);
  }
  const Eigen::Matrix3d normal_matrix = a.transpose() * a;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(normal_matrix);
  if (eigen.eigenvalues()(0) < 1e-12 * eigen.eigenvalues()(2))  // the planes do not fix the position
    return std::nullopt;
  const Eigen::Vector3d t = normal_matrix.ldlt().solve(a.transpose() * b);
  for (int i = 0; i < n; ++i)
  {
    const Eigen::Vector3d x0 = r * lines.point[i] + t;
    const Eigen::Vector3d x1 = r * (lines.point[i] + lines.direction[i]) + t;
    if (std::abs(normals[i].dot(r * lines.direction[i])) > max_residual ||
        std::abs(normals[i].dot(x0)) > max_residual * std::max(1.0, x0.norm()))
      return std::nullopt;
    if (x0.z() <= 0.0 && x1.z() <= 0.0)  // this line lies behind the camera (the yaw turned by 180 deg)
      return std::nullopt;
  }
  CameraPose pose;
  pose.rotation = r;
  pose.translation = t;
  return pose;
}
CameraModel pinHole(const CameraPose& pose, double focal_px, const Eigen::Vector2d& principal_point)
{
  Intrinsics in;
  in.fx = in.fy = focal_px;
  in.cx = principal_point.x();
  in.cy = principal_point.y();
  return CameraModel(in, DivisionModel{0.0, principal_point}, pose);
}
}  // namespace

std::vector<CameraModel> solveVerticalLinesFocalPose(const std::array<ImageMapLine, 4>& lines,
                                                     const Eigen::Vector2d& principal_point, int image_width,
                                                     const VerticalLinesSolverOptions& options)
{
  std::vector<CameraModel> cameras;
  NormalizedLines normalized;
  const double scale = std::max(1, image_width);
  if (!normalizeLines(lines.data(), lines.size(), principal_point, scale, options.vertical_tolerance_deg, &normalized))
    return cameras;
  // f / image width = 0.5 / tan(hfov / 2).
  const double f_min = 0.5 / std::tan(0.5 * options.max_fov_deg * kDegToRad);
  const double f_max = 0.5 / std::tan(0.5 * options.min_fov_deg * kDegToRad);
  for (double f : focalRoots(normalized, f_min, f_max, std::max(2, options.fov_samples)))
    for (double yaw : yawSystem(normalized, f).commonYaws(options.max_residual))
    {
      const FocalYaw root{f, yaw};
      const std::optional<CameraPose> pose = poseAt(normalized, root, options.max_residual);
      if (!pose)
        continue;
      cameras.push_back(pinHole(*pose, root.f * scale, principal_point));
    }
  return cameras;
}

std::vector<RotationFocal> solveVerticalLinesRotationFocal(const std::array<ImageMapLine, 4>& lines,
                                                           const Eigen::Vector2d& principal_point, int image_width,
                                                           const VerticalLinesSolverOptions& options)
{
  std::vector<RotationFocal> out;
  NormalizedLines normalized;
  const double scale = std::max(1, image_width);
  if (!normalizeLines(lines.data(), lines.size(), principal_point, scale, options.vertical_tolerance_deg, &normalized))
    return out;
  const double f_min = 0.5 / std::tan(0.5 * options.max_fov_deg * kDegToRad);
  const double f_max = 0.5 / std::tan(0.5 * options.min_fov_deg * kDegToRad);
  for (double f : focalRoots(normalized, f_min, f_max, std::max(2, options.fov_samples)))
  {
    const YawSystem s = yawSystem(normalized, f);
    for (double yaw : s.commonYaws(1e-6))
      out.push_back({s.tilt * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix(), f * scale});
  }
  return out;
}

std::vector<CameraModel> solveVerticalLinesPose(const std::array<ImageMapLine, 3>& lines,
                                                const Eigen::Vector2d& principal_point, int image_width,
                                                double focal_px, const VerticalLinesSolverOptions& options)
{
  std::vector<CameraModel> cameras;
  NormalizedLines normalized;
  const double scale = std::max(1, image_width);
  if (!(focal_px > 0.0) ||
      !normalizeLines(lines.data(), lines.size(), principal_point, scale, options.vertical_tolerance_deg, &normalized))
    return cameras;
  const double f = focal_px / scale;
  const YawSystem s = yawSystem(normalized, f);
  const double r = std::hypot(s.a[0], s.b[0]);
  if (r < 1e-12 || std::abs(s.c[0]) > r)  // line 2's plane cannot hold its 3D line's direction at this f
    return cameras;
  for (int branch : {-1, 1})
  {
    const double yaw = std::atan2(s.b[0], s.a[0]) + branch * std::acos(-s.c[0] / r);
    if (const std::optional<CameraPose> pose = poseAt(normalized, {f, yaw}, options.max_residual))
      cameras.push_back(pinHole(*pose, focal_px, principal_point));
  }
  return cameras;
}
}  // namespace insitu_calibration
