// The refinement's parameter blocks and its Ceres cost functions, one functor per kind of residual (in the manner
// of industrial_calibration's *_cost.h files): shared by the problem building and the uncertainty analysis.
#ifndef INSITU_CALIBRATION_REFINE_COST_FUNCTIONS_H
#define INSITU_CALIBRATION_REFINE_COST_FUNCTIONS_H

#include <Eigen/Core>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

namespace insitu_calibration
{
namespace refinement
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

// A direction line (CorrespondenceSet::direction_lines): an image point to the distorted image of the 3D line of
// direction d through the point C + cos(phi) e1 + sin(phi) e2 (C the optical centre, e1, e2 across d): a line in the
// plane through C that holds d, which phi turns about d. The line's image passes through d's vanishing point whatever
// phi; its position in the world does not enter (C cancels). d, e1 and e2 are turned about the world's z axis by the
// line's group's azimuth correction (a constant zero for an exact direction).
struct DirectionLineResidual
{
  Projector projector;
  Eigen::Vector3d direction;
  Eigen::Vector3d e1;
  Eigen::Vector3d e2;
  Eigen::Vector2d image;
  double weight = 1.0;  // 1 / the line's noise relative to the matched lines' (refinement.cpp, reweighDirectionLines)

  template <typename T>
  static void turnAboutZ(const T* azimuth, const Eigen::Vector3d& v, T* out)
  {
    out[0] = cos(azimuth[0]) * T(v.x()) - sin(azimuth[0]) * T(v.y());
    out[1] = sin(azimuth[0]) * T(v.x()) + cos(azimuth[0]) * T(v.y());
    out[2] = T(v.z());
  }

  template <typename T>
  bool operator()(const T* focal, const T* principal, const T* skew, const T* distortion, const T* delta,
                  const T* center, const T* phi, const T* azimuth, T* residual) const
  {
    T d[3], u1[3], u2[3];
    turnAboutZ(azimuth, direction, d);
    turnAboutZ(azimuth, e1, u1);
    turnAboutZ(azimuth, e2, u2);
    T a[3], b[3], ua[3], ub[3];
    for (int i = 0; i < 3; ++i)
    {
      a[i] = center[i] + cos(phi[0]) * u1[i] + sin(phi[0]) * u2[i];
      b[i] = center[i] + d[i];  // projects to the vanishing point
    }
    projector.undistortedHomogeneous(focal, skew, delta, center, a, ua);
    projector.undistortedHomogeneous(focal, skew, delta, center, b, ub);
    return ImagePointToLineResidual::distance(ua, ub, image, weight, principal, distortion, projector.r_ref2, residual);
  }
};

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

}  // namespace refinement
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_REFINE_COST_FUNCTIONS_H
