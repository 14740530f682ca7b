#include "insitu_calibration/lines/depth_registration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "insitu_calibration/lines/depth_sampler.h"
#include "insitu_calibration/lines/rgbd_lines.h"
#include "insitu_calibration/robust_statistics.h"

namespace insitu_calibration
{
namespace
{
// A pixel in the pinhole image (the undistorted image at the same focal length): inverse depth is affine there.
Eigen::Vector2d pinholePixel(const RgbdCamera& camera, const Eigen::Vector2d& pixel)
{
  if (!camera.hasDistortion())
    return pixel;
  const Eigen::Vector2d x = camera.normalize(pixel);
  const Intrinsics& k = camera.intrinsics;
  return {k.fx * x.x() + k.skew * x.y() + k.cx, k.fy * x.y() + k.cy};
}

// Inverse depth as an affine function of the pixel about a reference point: f = a (x - x0) + b (y - y0) + c.
struct SidePlane
{
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  // a, b, c
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

// Least squares with one round of trimming (readings beyond 3 robust sigmas: a second surface in the band, flying
// pixels). None with too few readings or a singular fit.
std::optional<SidePlane> fitSidePlane(const std::vector<Eigen::Vector3d>& readings, int min_pixels)
{
  std::vector<bool> used(readings.size(), true);
  SidePlane plane;
  for (int round = 0; round < 2; ++round)
  {
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d atb = Eigen::Vector3d::Zero();
    int n = 0;
    for (size_t i = 0; i < readings.size(); ++i)
      if (used[i])
      {
        const Eigen::Vector3d row(readings[i].x(), readings[i].y(), 1.0);
        ata += row * row.transpose();
        atb += row * readings[i].z();
        ++n;
      }
    if (n < min_pixels)
      return std::nullopt;
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(ata);
    if (ldlt.info() != Eigen::Success || ldlt.vectorD().minCoeff() <= 1e-9 * ldlt.vectorD().maxCoeff())
      return std::nullopt;
    plane.p = ldlt.solve(atb);
    std::vector<double> residuals(readings.size());
    double rss = 0.0;
    for (size_t i = 0; i < readings.size(); ++i)
    {
      residuals[i] = readings[i].z() - plane.p.dot(Eigen::Vector3d(readings[i].x(), readings[i].y(), 1.0));
      if (used[i])
        rss += residuals[i] * residuals[i];
    }
    plane.covariance = ldlt.solve(Eigen::Matrix3d::Identity()) * rss / std::max(1, n - 3);
    if (round == 1)
      break;
    std::vector<double> absolute;
    for (double r : residuals)
      absolute.push_back(std::abs(r));
    const double limit = 3.0 * robustSigma(absolute);
    for (size_t i = 0; i < readings.size(); ++i)
      used[i] = std::abs(residuals[i]) <= limit;
  }
  return plane;
}
}  // namespace

namespace
{
// The readings on each side of the segment (pinhole pixel relative to the segment's centre, inverse depth), in the
// band but not within inner_px of the segment nor end_margin_px of its ends.
void readSides(const cv::Mat& depth_m, const RgbdCamera& camera, const Segment2d& segment,
               const DepthRegistrationOptions& options, std::vector<Eigen::Vector3d> sides[2])
{
  const Eigen::Vector2d d = segment.direction(), n(-d.y(), d.x());
  const Eigen::Vector2d centre = 0.5 * (segment.a + segment.b);
  const Eigen::Vector2d centre_pinhole = pinholePixel(camera, centre);
  const double half = 0.5 * segment.length() - options.end_margin_px;
  const double reach = 0.5 * segment.length() + options.band_px + 1.0;
  const int x0 = std::max(0, static_cast<int>(std::floor(centre.x() - reach)));
  const int x1 = std::min(depth_m.cols - 1, static_cast<int>(std::ceil(centre.x() + reach)));
  const int y0 = std::max(0, static_cast<int>(std::floor(centre.y() - reach)));
  const int y1 = std::min(depth_m.rows - 1, static_cast<int>(std::ceil(centre.y() + reach)));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x)
    {
      const Eigen::Vector2d q(x, y);
      const double across = (q - centre).dot(n), along = (q - centre).dot(d);
      if (std::abs(across) < options.inner_px || std::abs(across) > options.band_px || std::abs(along) > half)
        continue;
      const float z = depth_m.at<float>(y, x);
      if (!std::isfinite(z) || !(z > 0.0f))
        continue;
      const Eigen::Vector2d p = pinholePixel(camera, q) - centre_pinhole;
      sides[across > 0.0 ? 1 : 0].emplace_back(p.x(), p.y(), 1.0 / z);
    }
}

// Whether the RGB edge stands alone: the grey profile across the segment (averaged along it) has its only strong
// step at the segment. A second edge in the band (a skirting board's top, a tile joint beside the corner, a door
// frame's rebate) makes the detected edge one of several features whose offset from the crease is the scene's, not
// the depth's, and the same in every frame that sees it.
bool isolatedEdge(const cv::Mat& grey, const Segment2d& segment, const DepthRegistrationOptions& options)
{
  if (grey.empty())
    return true;
  const Eigen::Vector2d d = segment.direction(), n(-d.y(), d.x());
  const double half = 0.5 * segment.length() - options.end_margin_px;
  const Eigen::Vector2d centre = 0.5 * (segment.a + segment.b);
  const int steps = static_cast<int>(2 * options.band_px / 0.5);
  std::vector<double> profile(steps + 1, 0.0);
  std::vector<int> counts(steps + 1, 0);
  for (double along = -half; along <= half; along += 1.0)
    for (int k = 0; k <= steps; ++k)
    {
      const Eigen::Vector2d q = centre + along * d + (-options.band_px + 0.5 * k) * n;
      if (q.x() < 0.0 || q.y() < 0.0 || q.x() > grey.cols - 1.0 || q.y() > grey.rows - 1.0)
        continue;
      cv::Mat patch;
      cv::getRectSubPix(grey, cv::Size(1, 1), cv::Point2f(static_cast<float>(q.x()), static_cast<float>(q.y())), patch,
                        CV_32F);
      profile[k] += patch.at<float>(0, 0);
      ++counts[k];
    }
  double edge = 0.0, elsewhere = 0.0;
  for (int k = 1; k <= steps; ++k)
  {
    if (counts[k] == 0 || counts[k - 1] == 0)
      return false;
    const double step = std::abs(profile[k] / counts[k] - profile[k - 1] / counts[k - 1]);
    const double offset = -options.band_px + 0.5 * (k - 0.5);
    double& strongest = std::abs(offset) <= options.edge_core_px ? edge : elsewhere;
    strongest = std::max(strongest, step);
  }
  return edge >= options.min_edge_step && elsewhere <= options.max_side_step_ratio * edge;
}

// A side's depth change per pixel relative to its depth (|grad z| / z = |grad f| / f for f = 1/z), at the segment's
// centre: a surface seen at a grazing angle, whose extrapolation meets a nearer surface's within a few pixels of an
// occluding edge (a door frame against a corridor wall seen along it) as if the two met at a crease.
double steepness(const SidePlane& plane)
{
  return plane.p.head<2>().norm() / std::abs(plane.p.z());
}
}  // namespace

std::optional<CreaseObservation> measureCrease(const cv::Mat& depth_m, const cv::Mat& grey, const RgbdCamera& camera,
                                               const Segment2d& segment, const DepthRegistrationOptions& options)
{
  const double usable = segment.length() - 2.0 * options.end_margin_px;
  if (!(usable > 2.0 * options.band_px) || depth_m.empty() || depth_m.type() != CV_32FC1)
    return std::nullopt;
  std::vector<Eigen::Vector3d> sides[2];
  readSides(depth_m, camera, segment, options, sides);
  const auto left = fitSidePlane(sides[0], options.min_side_pixels);
  const auto right = fitSidePlane(sides[1], options.min_side_pixels);
  if (!left || !right || !(steepness(*left) <= options.max_side_slope) ||
      !(steepness(*right) <= options.max_side_slope))
    return std::nullopt;
  // Where the two planes' inverse depths are equal, across the segment from its centre: t = -c / g. Across the
  // segment's ends it moves by usable * tan(the crease's angle to the segment): a shift moves no crease's angle.
  const Eigen::Vector2d d = segment.direction(), n(-d.y(), d.x());
  const Eigen::Vector3d delta = right->p - left->p;
  const double g = delta.x() * n.x() + delta.y() * n.y();
  const double tilt = delta.x() * d.x() + delta.y() * d.y();
  if (!(std::abs(g) > 0.0) || !(std::abs(tilt / g) * usable <= options.max_crease_tilt_px))
    return std::nullopt;
  const double t = -delta.z() / g;
  const Eigen::Vector3d jacobian = Eigen::Vector3d(-t * n.x(), -t * n.y(), -1.0) / g;
  const double sigma = std::sqrt(jacobian.dot((left->covariance + right->covariance) * jacobian));
  if (!(std::abs(t) <= options.max_crease_offset_px) || !(sigma <= options.max_crease_sigma_px) ||
      !isolatedEdge(grey, segment, options))
    return std::nullopt;
  CreaseObservation crease{n, t, std::hypot(sigma, options.edge_sigma_px)};
  // The crease in 3D (camera frame), on the left plane: for grouping the observations of one crease.
  const Eigen::Vector2d centre = 0.5 * (segment.a + segment.b);
  const auto pointAt = [&](const Eigen::Vector2d& pixel) -> Eigen::Vector3d {
    const Eigen::Vector2d p = pinholePixel(camera, pixel) - pinholePixel(camera, centre);
    const Eigen::Vector2d x = camera.normalize(pixel);
    return Eigen::Vector3d(x.x(), x.y(), 1.0) / left->p.dot(Eigen::Vector3d(p.x(), p.y(), 1.0));
  };
  crease.point = pointAt(centre);
  crease.direction = (pointAt(centre + 0.5 * usable * d) - pointAt(centre - 0.5 * usable * d)).normalized();
  return crease;
}

void DepthRegistrationEstimator::addFrame(const cv::Mat& depth_m, const cv::Mat& grey, const RgbdCamera& camera,
                                          const std::vector<Segment2d>& segments, const Eigen::Isometry3d& T_map_camera)
{
  ++frames_;
  for (const Segment2d& s : segments)
    if (auto crease = measureCrease(depth_m, grey, camera, s, options_))
    {
      crease->point = T_map_camera * crease->point;
      crease->direction = T_map_camera.linear() * crease->direction;
      creases_.push_back(*crease);
    }
}

Status DepthRegistrationEstimator::addFrame(const RgbdFrame& frame, const RgbdLineExtractor& extractor)
{
  if (Status valid = validateFrame(frame); !valid)
    return valid;
  const auto segments = extractor.detectSegments(frame.rgb);
  if (!segments)
    return segments.error();
  return addFrame(frame, *segments, extractor.options());
}

Status DepthRegistrationEstimator::addFrame(const RgbdFrame& frame, const std::vector<Segment2d>& segments,
                                            const RgbdLineOptions& options)
{
  if (Status valid = validateFrame(frame); !valid)
    return valid;
  const auto depth = depthToMeters(frame.depth, options.min_range_m, options.max_range_m);
  if (!depth)
    return depth.error();
  cv::Mat grey = frame.rgb;
  if (frame.rgb.channels() == 3)
    cv::cvtColor(frame.rgb, grey, cv::COLOR_BGR2GRAY);
  else if (frame.rgb.channels() == 4)
    cv::cvtColor(frame.rgb, grey, cv::COLOR_BGRA2GRAY);
  addFrame(*depth, grey, frame.camera, segments, frame.T_map_camera);
  return Success{};
}

Expected<DepthRegistrationEstimate> DepthRegistrationEstimator::estimate() const
{
  auto result = estimateRegistration(creases_, options_);
  if (result)
    result->frames = frames_;
  return result;
}

std::optional<Expected<DepthRegistrationEstimate>> DepthRegistrationEstimator::estimateWhenGrown(double growth)
{
  const double due = std::max(1.0, (1.0 + std::max(0.0, growth)) * static_cast<double>(creases_at_last_estimate_));
  if (creases_.size() <= creases_at_last_estimate_ || static_cast<double>(creases_.size()) < due)
    return std::nullopt;
  creases_at_last_estimate_ = creases_.size();
  return estimate();
}

namespace
{
// Groups the observations of one crease (the same 3D line, seen in several frames): per observation its group's
// size. Greedy: an observation joins the first group whose first member's line it lies on.
std::vector<double> groupSizes(const std::vector<CreaseObservation>& creases, const DepthRegistrationOptions& options,
                               size_t* groups)
{
  std::vector<size_t> group(creases.size()), first;
  std::vector<double> size;
  const double cos_max = std::cos(options.same_crease_deg * M_PI / 180.0);
  for (size_t i = 0; i < creases.size(); ++i)
  {
    const CreaseObservation& c = creases[i];
    size_t g = 0;
    for (; g < first.size(); ++g)
    {
      const CreaseObservation& f = creases[first[g]];
      const Eigen::Vector3d off = c.point - f.point;
      if (std::abs(c.direction.dot(f.direction)) >= cos_max &&
          (off - off.dot(f.direction) * f.direction).norm() <= options.same_crease_m)
        break;
    }
    if (g == first.size())
    {
      first.push_back(i);
      size.push_back(0.0);
    }
    group[i] = g;
    size[g] += 1.0;
  }
  *groups = first.size();
  std::vector<double> out(creases.size());
  for (size_t i = 0; i < creases.size(); ++i)
    out[i] = size[group[i]];
  return out;
}

// Weighted least squares of normal . s = -offset over the creases marked used, each crease (group) weighing as one
// observation: its frames repeat its RGB edge's error. None when singular.
std::optional<std::pair<Eigen::Vector2d, Eigen::Matrix2d>> solveCreases(const std::vector<CreaseObservation>& creases,
                                                                        const std::vector<double>& group_size,
                                                                        const std::vector<bool>& used)
{
  Eigen::Matrix2d information = Eigen::Matrix2d::Zero();
  Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < creases.size(); ++i)
    if (used[i])
    {
      const double w = 1.0 / (creases[i].sigma_px * creases[i].sigma_px * group_size[i]);
      information += w * creases[i].normal * creases[i].normal.transpose();
      rhs -= w * creases[i].offset_px * creases[i].normal;
    }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(information);
  if (!(eigen.eigenvalues().minCoeff() > 0.0))
    return std::nullopt;
  const Eigen::Matrix2d covariance = information.inverse();
  return std::make_pair(Eigen::Vector2d(covariance * rhs), covariance);
}

double normalisedResidual(const CreaseObservation& c, const Eigen::Vector2d& s)
{
  return (c.normal.dot(s) + c.offset_px) / c.sigma_px;
}
}  // namespace

Expected<DepthRegistrationEstimate> estimateRegistration(const std::vector<CreaseObservation>& creases,
                                                         const DepthRegistrationOptions& options)
{
  size_t groups = 0;
  const std::vector<double> group_size = groupSizes(creases, options, &groups);
  const auto notEnough = [&](size_t count) {
    return Error(ErrorCode::kNotEnoughData,
                 "depth registration: " + std::to_string(count) +
                     " creases (two surfaces meeting without a depth jump) found, " +
                     std::to_string(options.min_creases) +
                     " needed; survey corners and edges of walls, floor and furniture from near, or give the offset");
  };
  if (groups < options.min_creases)
    return notEnough(groups);
  std::vector<bool> used(creases.size(), true);
  DepthRegistrationEstimate e;
  for (int round = 0; round < 6; ++round)
  {
    const auto solved = solveCreases(creases, group_size, used);
    if (!solved)
      break;
    e.offset_px = solved->first;
    std::vector<double> absolute;
    for (const CreaseObservation& c : creases)
      absolute.push_back(std::abs(normalisedResidual(c, e.offset_px)));
    // The creases' own sigmas miss correlated noise and the RGB edge's error: their scale from the residuals.
    const double scale = std::max(robustSigma(absolute), 1e-6);
    for (size_t i = 0; i < creases.size(); ++i)
      used[i] = absolute[i] <= options.outlier_sigmas * scale;
  }
  const auto solved = solveCreases(creases, group_size, used);
  e.observations = static_cast<size_t>(std::count(used.begin(), used.end(), true));
  e.trimmed = creases.size() - e.observations;
  double used_groups = 0.0, chi2 = 0.0;
  for (size_t i = 0; i < creases.size(); ++i)
    if (used[i])
    {
      used_groups += 1.0 / group_size[i];
      if (solved)
        chi2 += std::pow(normalisedResidual(creases[i], solved->first), 2) / group_size[i];
    }
  e.creases = static_cast<size_t>(std::lround(used_groups));
  if (!solved || e.creases < options.min_creases)
    return !solved ? Error(ErrorCode::kDegenerate, "depth registration: the creases are all of one direction")
                   : notEnough(e.creases);
  e.offset_px = solved->first;
  // The scatter per crease (a group's frames counted once), against the dof of the creases.
  e.scatter = std::sqrt(chi2 / std::max(1.0, used_groups - 2.0));
  e.covariance = solved->second * std::max(1.0, e.scatter * e.scatter);
  e.sigma_px = e.covariance.diagonal().cwiseSqrt();
  const double worst = std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(e.covariance).eigenvalues().maxCoeff());
  if (!(worst <= options.max_sigma_px))
  {
    std::ostringstream why;
    why << "depth registration: " << e.creases << " creases determine the offset (" << e.offset_px.x() << ", "
        << e.offset_px.y() << " px, scatter " << e.scatter << ") only to " << worst << " px (1 sigma; "
        << options.max_sigma_px
        << " px needed): too few directions or too scattered; survey corners of several directions, or give the offset";
    return Error(ErrorCode::kDegenerate, why.str());
  }
  return e;
}

double registrationDiscrepancySigmas(const DepthRegistrationEstimate& estimate, const Eigen::Vector2d& offset_px)
{
  const Eigen::Vector2d d = offset_px - estimate.offset_px;
  if (d.isZero(0.0))
    return 0.0;
  const Eigen::LDLT<Eigen::Matrix2d> ldlt(estimate.covariance);
  if (ldlt.info() == Eigen::Success && ldlt.isPositive() && estimate.covariance.determinant() > 1e-24)
    return std::sqrt(std::max(0.0, d.dot(ldlt.solve(d))));
  const double sigma = estimate.sigma_px.maxCoeff();
  return sigma > 0.0 ? d.norm() / sigma : std::numeric_limits<double>::infinity();
}

std::string registrationDisagreementAdvice(const DepthRegistrationEstimate& e, const Eigen::Vector2d& offset_px,
                                           double max_sigmas)
{
  const double apart = registrationDiscrepancySigmas(e, offset_px);
  if (!(apart > max_sigmas))
    return "";
  char text[480];
  std::snprintf(text, sizeof(text),
                "the survey's depth was read at a registration of %.3f, %.3f px, but its creases give %.3f, %.3f px "
                "(1 sigma %.3f, %.3f px; %.1f sigma apart): map lines on surfaces seen at a grazing angle may be "
                "millimetres off. For the best accuracy set depth_registration/x_px, y_px to the estimate and "
                "sigma_px to %.3f, and survey again",
                offset_px.x(), offset_px.y(), e.offset_px.x(), e.offset_px.y(), e.sigma_px.x(), e.sigma_px.y(), apart,
                std::max(e.sigma_px.maxCoeff(), 0.001));  // never 0: sigma_px 0 means exact
  return text;
}

}  // namespace insitu_calibration
