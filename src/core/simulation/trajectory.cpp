#include "insitu_calibration/simulation/trajectory.h"

#include <cmath>

#include "insitu_calibration/geometry/optical_frame.h"

namespace insitu_calibration
{
namespace simulation
{
namespace
{
double wrapAngle(double a)
{
  return std::atan2(std::sin(a), std::cos(a));
}

// A body frame's optical frame (REP 103) as the transform frame_from_optical.
Eigen::Isometry3d frameFromOptical()
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = bodyFromOpticalRotation();
  return t;
}

Eigen::Isometry3d translation(const Eigen::Vector3d& v)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = v;
  return t;
}
}  // namespace

RouteTrajectory::RouteTrajectory(const Route& route) : loop_(route.loop)
{
  const auto& w = route.waypoints;
  const double omega = route.turn_rate_deg * M_PI / 180.0;
  std::vector<Eigen::Vector2d> stops(w.begin(), w.end());
  if (route.loop)
    stops.push_back(w.front());
  Pose2d current{w[0].x(), w[0].y(), std::atan2(w[1].y() - w[0].y(), w[1].x() - w[0].x())};
  const double first_heading = current.yaw;
  double t = 0.0;
  auto turnTo = [&](double heading) {
    const double delta = wrapAngle(heading - current.yaw);
    if (std::abs(delta) < 1e-12)
      return;
    Pose2d to = current;
    to.yaw = current.yaw + delta;
    const double duration = std::abs(delta) / omega;
    phases_.push_back({t, t + duration, current, to});
    t += duration;
    current = to;
  };
  for (size_t i = 0; i + 1 < stops.size(); ++i)
  {
    const Eigen::Vector2d d = stops[i + 1] - stops[i];
    turnTo(std::atan2(d.y(), d.x()));
    Pose2d to{stops[i + 1].x(), stops[i + 1].y(), current.yaw};
    const double duration = d.norm() / route.speed;
    phases_.push_back({t, t + duration, current, to});
    t += duration;
    current = to;
  }
  if (route.loop)
    turnTo(first_heading);
  lap_ = t;
}

Pose2d RouteTrajectory::at(double t) const
{
  if (phases_.empty())
    return {};
  if (loop_ && lap_ > 0.0)
    t = std::fmod(std::max(0.0, t), lap_);
  if (t <= 0.0)
    return phases_.front().from;
  if (t >= lap_)
    return phases_.back().to;
  // Binary search for the phase.
  size_t lo = 0, hi = phases_.size() - 1;
  while (lo < hi)
  {
    const size_t mid = (lo + hi) / 2;
    if (phases_[mid].t1 < t)
      lo = mid + 1;
    else
      hi = mid;
  }
  const Phase& p = phases_[lo];
  const double s = p.t1 > p.t0 ? (t - p.t0) / (p.t1 - p.t0) : 1.0;
  return {p.from.x + s * (p.to.x - p.from.x), p.from.y + s * (p.to.y - p.from.y),
          wrapAngle(p.from.yaw + s * (p.to.yaw - p.from.yaw))};
}

Eigen::Isometry3d pose2dToIsometry(const Pose2d& pose)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(pose.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  t.translation() = Eigen::Vector3d(pose.x, pose.y, 0.0);
  return t;
}

Eigen::Isometry3d RouteTrajectory::mapFromBase(double t) const
{
  return pose2dToIsometry(at(t));
}

std::vector<Eigen::Vector2d> RouteTrajectory::pathPoints(double step) const
{
  std::vector<Eigen::Vector2d> points;
  for (const Phase& p : phases_)
  {
    const Eigen::Vector2d a(p.from.x, p.from.y), b(p.to.x, p.to.y);
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
    for (int i = 0; i <= n; ++i)
      points.push_back(a + (b - a) * (static_cast<double>(i) / n));
  }
  return points;
}

std::vector<NamedTransform> xtionStaticTransforms(const XtionConfig& x)
{
  Eigen::Isometry3d base_from_link = Eigen::Isometry3d::Identity();
  base_from_link.translation() = Eigen::Vector3d(x.mount_forward_m, 0.0, x.mount_height_m);
  // Positive tilt looks up: a negative pitch about y.
  base_from_link.linear() = Eigen::AngleAxisd(-x.tilt_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return {
      {"base_link", "camera_link", base_from_link},
      {"camera_link", "camera_rgb_frame", translation(x.rgb_offset)},
      {"camera_rgb_frame", "camera_rgb_optical_frame", frameFromOptical()},
      {"camera_link", "camera_depth_frame", translation(x.depth_offset)},
      {"camera_depth_frame", "camera_depth_optical_frame", frameFromOptical()},
  };
}

Eigen::Isometry3d baseFromRgbOptical(const XtionConfig& x)
{
  const auto t = xtionStaticTransforms(x);
  return t[0].transform * t[1].transform * t[2].transform;
}

}  // namespace simulation
}  // namespace insitu_calibration
