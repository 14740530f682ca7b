#include "insitu_calibration/lines/line3d_fitter.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <memory>

#include <Eigen/Dense>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_line.h>

#include "insitu_calibration/io/parameter_range.h"
#include "insitu_calibration/robust_statistics.h"

namespace insitu_calibration
{
namespace
{
// PCL's line model with its sample generator seeded by the caller (PCL seeds it with a constant or the time).
class SeededLineModel : public pcl::SampleConsensusModelLine<pcl::PointXYZ>
{
public:
  SeededLineModel(const PointCloudConstPtr& cloud, uint32_t seed)
      : pcl::SampleConsensusModelLine<pcl::PointXYZ>(cloud, false)
  {
    rng_alg_.seed(seed);
  }
};

struct Consensus
{
  std::vector<int> inliers;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
};

double thresholdFor(const std::vector<Eigen::Vector3d>& points, const Line3dFitOptions& options)
{
  std::vector<double> z;
  z.reserve(points.size());
  for (const auto& p : points)
    z.push_back(p.z());
  double range = middleValue(z);
  if (!(range > 0.0))
  {
    z.clear();
    for (const auto& p : points)
      z.push_back(p.norm());
    range = middleValue(z);
  }
  return options.threshold_m + options.threshold_per_m2 * range * range;
}

Status checkOptions(const Line3dFitOptions& o)
{
  if (!(o.threshold_m >= 0.0) || !(o.threshold_per_m2 >= 0.0) || o.threshold_m + o.threshold_per_m2 <= 0.0 ||
      o.max_iterations < 1 || !(o.probability > 0.0 && o.probability < 1.0) || o.min_inliers < 2 ||
      !(o.min_inlier_ratio >= 0.0 && o.min_inlier_ratio <= 1.0) || !(o.min_length_m >= 0.0))
    return Error(ErrorCode::kInvalidInput,
                 "invalid 3D line fitting options (thresholds >= 0 and not both 0, "
                 "max_iterations >= 1, probability in (0, 1), min_inliers >= 2, "
                 "min_inlier_ratio in [0, 1], min_length_m >= 0)");
  return Success();
}

Expected<Consensus> ransacLine(const std::vector<Eigen::Vector3d>& points, double threshold,
                               const Line3dFitOptions& options)
{
  const size_t needed = std::max<size_t>(static_cast<size_t>(options.min_inliers), 2);
  if (points.size() < needed)
    return Error(ErrorCode::kNotEnoughData,
                 std::to_string(points.size()) + " points, " + std::to_string(needed) + " needed for a 3D line");
  // Points that span less than the minimum length make no line (and would make PCL's sampler complain).
  Eigen::Vector3d lo = points.front(), hi = points.front();
  for (const auto& p : points)
  {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  if ((hi - lo).norm() < std::max(options.min_length_m, 1e-6))
    return Error(ErrorCode::kDegenerate,
                 "the points span " + std::to_string((hi - lo).norm()) + " m, less than the minimum line length");
  try
  {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->reserve(points.size());
    for (const auto& p : points)
      cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    auto model = std::make_shared<SeededLineModel>(cloud, options.seed);
    pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, threshold);
    ransac.setMaxIterations(options.max_iterations);
    ransac.setProbability(options.probability);
    if (!ransac.computeModel())
      return Error(ErrorCode::kNoSolution, "RANSAC found no 3D line");
    Consensus c;
    pcl::Indices inliers;
    ransac.getInliers(inliers);
    c.inliers.assign(inliers.begin(), inliers.end());
    Eigen::VectorXf coefficients;
    ransac.getModelCoefficients(coefficients);
    if (coefficients.size() != 6)
      return Error(ErrorCode::kNoSolution, "RANSAC returned no line model");
    c.point = coefficients.head<3>().cast<double>();
    c.direction = coefficients.tail<3>().cast<double>().normalized();
    const double required = std::max<double>(options.min_inliers, options.min_inlier_ratio * points.size());
    if (static_cast<double>(c.inliers.size()) < required)
      return Error(ErrorCode::kNoSolution, "RANSAC's best line has " + std::to_string(c.inliers.size()) + " of " +
                                               std::to_string(points.size()) + " points as inliers (" +
                                               std::to_string(static_cast<int>(std::ceil(required))) + " needed)");
    return c;
  }
  catch (const std::exception& e)
  {
    return Error(ErrorCode::kNoSolution, std::string("PCL's RANSAC failed: ") + e.what());
  }
}

// Total least squares (PCA) of the selected points.
void pcaLine(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& selected, Eigen::Vector3d* point,
             Eigen::Vector3d* direction)
{
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i : selected)
    mean += points[i];
  mean /= static_cast<double>(selected.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i : selected)
    cov += (points[i] - mean) * (points[i] - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  *point = mean;
  *direction = eig.eigenvectors().col(2).normalized();
}

// End points = extent of the selected points on the line; RMS of their distances.
Line3d finishLine(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& selected,
                  const Eigen::Vector3d& point, const Eigen::Vector3d& direction)
{
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, sum2 = 0.0;
  for (int i : selected)
  {
    const Eigen::Vector3d r = points[i] - point;
    const double s = r.dot(direction);
    lo = std::min(lo, s);
    hi = std::max(hi, s);
    sum2 += (r - s * direction).squaredNorm();
  }
  Line3d line;
  line.a = point + lo * direction;
  line.b = point + hi * direction;
  line.inliers = static_cast<int>(selected.size());
  line.samples = static_cast<int>(points.size());
  line.rms_m = std::sqrt(sum2 / std::max<size_t>(1, selected.size()));
  line.range_m = (0.5 * (line.a + line.b)).norm();
  return line;
}

Status checkLength(const Line3d& line, const Line3dFitOptions& options)
{
  if (line.length() < options.min_length_m)
    return Error(ErrorCode::kDegenerate, "the inliers span " + formatParameterValue(line.length()) + " m, less than " +
                                             formatParameterValue(options.min_length_m) + " m");
  return Success();
}

// Total least squares on the inliers, then the inliers of the refined line, up to three times; stops early when the
// consensus would shrink (the larger one is kept).
void refinePcaLine(const std::vector<Eigen::Vector3d>& points, double threshold, std::vector<int>* inliers,
                   Eigen::Vector3d* point, Eigen::Vector3d* direction)
{
  for (int round = 0; round < 3; ++round)
  {
    pcaLine(points, *inliers, point, direction);
    if (round == 2)
      break;
    std::vector<int> next;
    for (size_t i = 0; i < points.size(); ++i)
    {
      const Eigen::Vector3d r = points[i] - *point;
      if ((r - r.dot(*direction) * *direction).norm() <= threshold)
        next.push_back(static_cast<int>(i));
    }
    if (next.size() < inliers->size())
      break;
    inliers->swap(next);
  }
}

// Depth samples back-projected (camera frame, m) with their parameter t along the normalised 2D segment xa + t xab.
// Also the kept samples themselves (kept: for their depth slopes across the edge and their sides' depths).
void backProjectSamples(const std::vector<DepthSample>& samples, const RgbdCamera& camera, const Eigen::Vector2d& xa,
                        const Eigen::Vector2d& xab, std::vector<Eigen::Vector3d>* points, std::vector<double>* t,
                        std::vector<DepthSample>* kept)
{
  points->reserve(samples.size());
  t->reserve(samples.size());
  for (const auto& s : samples)
  {
    if (!(s.depth_m > 0.0) || !std::isfinite(s.depth_m) || !s.pixel.allFinite())
      continue;
    const Eigen::Vector2d x = camera.normalize(s.pixel);
    points->push_back(s.depth_m * x.homogeneous());
    t->push_back((x - xa).dot(xab) / xab.squaredNorm());
    kept->push_back(s);
  }
}

// Line3d::sigma_systematic_m: the registration's uncertainty times the depth's gradient at the edge, along the ray.
// Across the edge: the steeper side's median slope over the samples (one sample's slope, from 4 readings, is mostly
// noise); along it: z^2 |dv/ds| per px from the line's end points (inverse depth is affine along the segment).
// px_per_unit: image pixels per unit of normalised coordinates.
double registrationSigma(const Line3d& line, const std::vector<DepthSample>& samples, double px_per_unit,
                         double sigma_px)
{
  if (!(sigma_px > 0.0) || samples.empty() || !(px_per_unit > 0.0) || !(line.a.z() > 0.0 && line.b.z() > 0.0))
    return 0.0;
  std::vector<double> left, right;
  for (const DepthSample& s : samples)
  {
    left.push_back(s.depth_slope_m_per_px.x());
    right.push_back(s.depth_slope_m_per_px.y());
  }
  const double across = std::max(std::abs(middleValue(left)), std::abs(middleValue(right)));
  const Eigen::Vector3d mid = 0.5 * (line.a + line.b);
  const double span_px = px_per_unit * (line.a.head<2>() / line.a.z() - line.b.head<2>() / line.b.z()).norm();
  const double along = mid.z() * mid.z() * std::abs(1.0 / line.b.z() - 1.0 / line.a.z()) / std::max(span_px, 1e-9);
  return sigma_px * std::hypot(across, along) * mid.norm() / mid.z();
}

// Inverse depth v = alpha + beta t along the 2D segment.
struct InverseDepthLine
{
  double alpha = 0.0;
  double beta = 0.0;
};

// Least squares on the inliers; then the inliers again by their depth residual, and a final fit (RANSAC's inliers
// and the fit are kept when the new inliers would be too few).
Expected<InverseDepthLine> fitInverseDepth(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& t,
                                           double threshold, const Line3dFitOptions& options, std::vector<int>* inliers)
{
  InverseDepthLine fit;
  for (int round = 0; round < 3; ++round)
  {
    double sw = 0.0, st = 0.0, sv = 0.0, stt = 0.0, stv = 0.0;
    for (int i : *inliers)
    {
      const double v = 1.0 / points[i].z();
      sw += 1.0;
      st += t[i];
      sv += v;
      stt += t[i] * t[i];
      stv += t[i] * v;
    }
    const double var = stt - st * st / sw;
    if (!(var > 1e-12 * sw))
      return Error(ErrorCode::kDegenerate, "the depth samples do not spread along the segment");
    fit.beta = (stv - st * sv / sw) / var;
    fit.alpha = (sv - fit.beta * st) / sw;
    if (round == 2)
      break;
    std::vector<int> next;
    for (size_t i = 0; i < points.size(); ++i)
    {
      const double v = fit.alpha + fit.beta * t[i];
      if (v > 0.0 && std::abs(points[i].z() - 1.0 / v) <= threshold)
        next.push_back(static_cast<int>(i));
    }
    const double required = std::max<double>(options.min_inliers, options.min_inlier_ratio * points.size());
    if (static_cast<double>(next.size()) < required)
      break;
    inliers->swap(next);
  }
  return fit;
}

// The larger standard error of the two end points: that of the inverse depth at each end (affine least squares),
// then along its ray: sigma_z = sigma_v z^2, times the ray's length per unit z.
double inverseDepthEndSigma(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& t,
                            const std::vector<int>& inliers, const InverseDepthLine& fit, double t_lo, double t_hi,
                            const Eigen::Vector3d& pa, const Eigen::Vector3d& pb)
{
  double t_mean = 0.0;
  for (int i : inliers)
    t_mean += t[i];
  t_mean /= static_cast<double>(inliers.size());
  double stt = 0.0, rss = 0.0;
  for (int i : inliers)
  {
    stt += (t[i] - t_mean) * (t[i] - t_mean);
    const double r = 1.0 / points[i].z() - fit.alpha - fit.beta * t[i];
    rss += r * r;
  }
  const double n = static_cast<double>(inliers.size());
  const double sigma_v = std::sqrt(rss / std::max(1.0, n - 2.0));
  auto end_sigma = [&](double t_end, double v_end, const Eigen::Vector3d& p) {
    const double var = sigma_v * sigma_v * (1.0 / n + (t_end - t_mean) * (t_end - t_mean) / std::max(stt, 1e-12));
    return std::sqrt(var) / (v_end * v_end) * p.norm() / p.z();
  };
  return std::max(end_sigma(t_lo, fit.alpha + fit.beta * t_lo, pa), end_sigma(t_hi, fit.alpha + fit.beta * t_hi, pb));
}

// The line each side's depth gives (Line3d::side_a / side_b) and the step between the sides, over the inliers: each
// side's inverse depth affine along the segment like the line's, from t_lo to t_hi.
void addDepthSides(const std::vector<DepthSample>& samples, const std::vector<double>& t,
                   const std::vector<int>& inliers, const Eigen::Vector2d& xa, const Eigen::Vector2d& xab, double t_lo,
                   double t_hi, Line3d* line)
{
  std::vector<DepthSample> selected;
  for (int i : inliers)
    selected.push_back(samples[i]);
  line->depth_step = measureDepthStep(selected);
  for (int side = 0; side < 2; ++side)
  {
    double sw = 0.0, st = 0.0, sv = 0.0, stt = 0.0, stv = 0.0;
    for (int i : inliers)
    {
      const double v = samples[i].side_inverse_depth(side);
      if (!(std::isfinite(v) && v > 0.0))
        continue;
      sw += 1.0;
      st += t[i];
      sv += v;
      stt += t[i] * t[i];
      stv += t[i] * v;
    }
    const double var = stt - (sw > 0.0 ? st * st / sw : 0.0);
    if (sw < 8.0 || !(var > 1e-12 * sw))
      continue;
    const double beta = (stv - st * sv / sw) / var, alpha = (sv - beta * st) / sw;
    const double va = alpha + beta * t_lo, vb = alpha + beta * t_hi;
    if (!(va > 0.0 && vb > 0.0))
      continue;
    line->side_a[side] = (xa + t_lo * xab).homogeneous() / va;
    line->side_b[side] = (xa + t_hi * xab).homogeneous() / vb;
  }
}

// The 3D line whose inverse depth is affine along the 2D segment (xa + t xab, normalised coordinates); its extent is
// the inliers' on the image line. samples: the points' depth samples (their sides' depths).
Expected<Line3d> inverseDepthLine(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& t,
                                  const std::vector<DepthSample>& samples, const Eigen::Vector2d& xa,
                                  const Eigen::Vector2d& xab, double threshold, const Line3dFitOptions& options,
                                  std::vector<int> inliers)
{
  const Expected<InverseDepthLine> fit = fitInverseDepth(points, t, threshold, options, &inliers);
  if (!fit)
    return fit.error();
  double t_lo = std::numeric_limits<double>::infinity(), t_hi = -t_lo;
  for (int i : inliers)
  {
    t_lo = std::min(t_lo, t[i]);
    t_hi = std::max(t_hi, t[i]);
  }
  const double va = fit->alpha + fit->beta * t_lo, vb = fit->alpha + fit->beta * t_hi;
  if (!(va > 0.0 && vb > 0.0))
    return Error(ErrorCode::kDegenerate, "the fitted 3D line passes behind the camera");
  const Eigen::Vector3d pa = (xa + t_lo * xab).homogeneous() / va;
  const Eigen::Vector3d pb = (xa + t_hi * xab).homogeneous() / vb;
  Line3d line = finishLine(points, inliers, pa, (pb - pa).normalized());
  line.a = pa;
  line.b = pb;
  line.sigma_m = inverseDepthEndSigma(points, t, inliers, *fit, t_lo, t_hi, pa, pb);
  addDepthSides(samples, t, inliers, xa, xab, t_lo, t_hi, &line);
  return line;
}
}  // namespace

void Line3d::transform(const Eigen::Isometry3d& T)
{
  a = T * a;
  b = T * b;
  for (int side = 0; side < 2; ++side)
  {
    side_a[side] = T * side_a[side];
    side_b[side] = T * side_b[side];
  }
  if (sensor.allFinite())
    sensor = T * sensor;
}

Expected<Line3d> fitLine3d(const std::vector<Eigen::Vector3d>& points, const Line3dFitOptions& options)
{
  if (auto s = checkOptions(options); !s)
    return s.error();
  std::vector<Eigen::Vector3d> finite;
  finite.reserve(points.size());
  for (const auto& p : points)
    if (p.allFinite())
      finite.push_back(p);
  if (finite.size() < static_cast<size_t>(std::max(2, options.min_inliers)))
    return Error(ErrorCode::kNotEnoughData, std::to_string(finite.size()) + " finite points, " +
                                                std::to_string(std::max(2, options.min_inliers)) + " needed");
  const double threshold = thresholdFor(finite, options);
  auto consensus = ransacLine(finite, threshold, options);
  if (!consensus)
    return consensus.error();
  // Refinement: total least squares on the inliers, then the inliers of the refined line, twice.
  std::vector<int> inliers = consensus->inliers;
  Eigen::Vector3d point, direction;
  refinePcaLine(finite, threshold, &inliers, &point, &direction);
  Line3d line = finishLine(finite, inliers, point, direction);
  line.samples = static_cast<int>(points.size());
  if (auto s = checkLength(line, options); !s)
    return s.error();
  return line;
}

Expected<Line3d> fitLine3dToDepthSamples(const Segment2d& segment, const std::vector<DepthSample>& samples,
                                         const RgbdCamera& camera, const Line3dFitOptions& options)
{
  if (auto s = checkOptions(options); !s)
    return s.error();
  if (auto s = camera.validate(); !s)
    return s.error();
  if (!segment.a.allFinite() || !segment.b.allFinite() || !(segment.length() > 0.0))
    return Error(ErrorCode::kInvalidInput, "the 2D segment is degenerate or not finite");
  const Eigen::Vector2d xa = camera.normalize(segment.a);
  const Eigen::Vector2d xab = camera.normalize(segment.b) - xa;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> t;
  std::vector<DepthSample> kept;
  backProjectSamples(samples, camera, xa, xab, &points, &t, &kept);
  if (points.size() < static_cast<size_t>(std::max(2, options.min_inliers)))
    return Error(ErrorCode::kNotEnoughData, std::to_string(points.size()) + " depth samples along the segment, " +
                                                std::to_string(std::max(2, options.min_inliers)) + " needed");
  const double threshold = thresholdFor(points, options);
  auto consensus = ransacLine(points, threshold, options);
  if (!consensus)
    return consensus.error();

  Line3d line;
  if (options.refinement == Line3dRefinement::kPca)
  {
    std::vector<int> inliers = consensus->inliers;
    Eigen::Vector3d point, direction;
    refinePcaLine(points, threshold, &inliers, &point, &direction);
    line = finishLine(points, inliers, point, direction);
    line.sigma_m = 2.0 * line.rms_m / std::sqrt(static_cast<double>(std::max<size_t>(1, inliers.size())));
  }
  else
  {
    auto fitted = inverseDepthLine(points, t, kept, xa, xab, threshold, options, consensus->inliers);
    if (!fitted)
      return fitted.error();
    line = *fitted;
  }
  const double required = std::max<double>(options.min_inliers, options.min_inlier_ratio * points.size());
  if (static_cast<double>(line.inliers) < required)
    return Error(ErrorCode::kNoSolution,
                 std::to_string(line.inliers) + " inliers of " + std::to_string(points.size()) + " depth samples");
  line.samples = static_cast<int>(samples.size());
  line.sigma_systematic_m = registrationSigma(line, kept, segment.length() / xab.norm(), options.registration_sigma_px);
  line.image = segment;
  line.sensor = Eigen::Vector3d::Zero();
  if (auto s = checkLength(line, options); !s)
    return s.error();
  return line;
}

}  // namespace insitu_calibration
