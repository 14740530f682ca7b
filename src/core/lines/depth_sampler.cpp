#include "insitu_calibration/lines/depth_sampler.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Dense>

namespace insitu_calibration
{
namespace
{
// The valid depth readings in a band of +-band pixels across the edge at one sample: each pixel's signed offset from
// the edge (its centre, across it) and its depth, in the order of the offsets (a view into SegmentBands' arrays); the
// nearest reading and its offset.
struct BandReadings
{
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  double position = 0.0;  // along the segment from its first end, px
  const double* offsets = nullptr;
  const double* depths = nullptr;
  size_t size = 0;
  double z_min = std::numeric_limits<double>::infinity();  // infinity when there is no reading
  double z_min_offset = 0.0;
};

// Every sample's band, read once (at a + position * d, d the segment's unit direction): the slant allowance needs
// them all before the first sample is measured.
struct SegmentBands
{
  SegmentBands() = default;
  SegmentBands(SegmentBands&&) = default;  // a move keeps the arrays' buffers, which the bands point into
  SegmentBands(const SegmentBands&) = delete;
  SegmentBands& operator=(const SegmentBands&) = delete;
  std::vector<double> offsets, depths;
  std::vector<BandReadings> bands;
};

SegmentBands readBands(const cv::Mat& depth_m, const Eigen::Vector2d& a, const Eigen::Vector2d& d,
                       const std::vector<double>& positions, int band, const Eigen::Vector2d& registration_offset)
{
  SegmentBands out;
  out.offsets.reserve(positions.size() * (2 * band + 1));
  out.depths.reserve(positions.size() * (2 * band + 1));
  out.bands.reserve(positions.size());
  std::vector<size_t> begin;
  begin.reserve(positions.size() + 1);
  const Eigen::Vector2d n(-d.y(), d.x());
  for (const double s : positions)
  {
    BandReadings r;
    r.pixel = a + s * d;
    r.position = s;
    begin.push_back(out.depths.size());
    for (int j = -band; j <= band; ++j)
    {
      const Eigen::Vector2d q = r.pixel + static_cast<double>(j) * n;
      const int x = static_cast<int>(std::lround(q.x()));
      const int y = static_cast<int>(std::lround(q.y()));
      if (x < 0 || y < 0 || x >= depth_m.cols || y >= depth_m.rows)
        continue;
      const float z = depth_m.at<float>(y, x);
      if (!std::isfinite(z))
        continue;
      out.offsets.push_back((Eigen::Vector2d(x, y) + registration_offset - r.pixel).dot(n));
      out.depths.push_back(z);
      if (z < r.z_min)
      {
        r.z_min = z;
        r.z_min_offset = out.offsets.back();
      }
    }
    out.bands.push_back(r);
  }
  begin.push_back(out.depths.size());
  for (size_t i = 0; i < out.bands.size(); ++i)  // the arrays are complete: no more reallocation
  {
    out.bands[i].offsets = out.offsets.data() + begin[i];
    out.bands[i].depths = out.depths.data() + begin[i];
    out.bands[i].size = begin[i + 1] - begin[i];
  }
  return out;
}

// True when one side of the edge has no reading in the band and the first reading beyond it (up to search_px across
// the edge) is nearer than near_limit.
bool occludedBySurfaceBeyondGap(const cv::Mat& depth_m, const BandReadings& readings, const Eigen::Vector2d& n,
                                int band, int search_px, double near_limit)
{
  if (search_px <= band)
    return false;
  for (const double side : {-1.0, 1.0})
  {
    bool seen = false;
    for (size_t k = 0; k < readings.size; ++k)
      seen |= side * readings.offsets[k] > 0.25;
    if (seen)
      continue;
    for (int j = band + 1; j <= search_px; ++j)
    {
      const Eigen::Vector2d q = readings.pixel + side * static_cast<double>(j) * n;
      const int x = static_cast<int>(std::lround(q.x()));
      const int y = static_cast<int>(std::lround(q.y()));
      if (x < 0 || y < 0 || x >= depth_m.cols || y >= depth_m.rows)
        break;
      const float z = depth_m.at<float>(y, x);
      if (!std::isfinite(z))
        continue;
      if (z < near_limit)
        return true;
      break;
    }
  }
  return false;
}

double medianInPlace(std::vector<double>& v)
{
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// How fast depth grows across the edge where the surfaces are seen slanted, m per px of offset: per side the median
// of neighbouring readings' depth differences over the whole segment, and of the two sides the smaller magnitude (a
// background receding faster than the near surface must still be told from it). Without it a reading counts as far
// when it lies a jump behind the nearest one, which on a wall seen at a grazing angle (2 cm per px at 4.5 m) keeps
// only the samples whose deeper side happens to read near: a false step of several mm, the same in every frame, and
// an edge depth biased nearer. 0 where a side has too few differences.
double slantAllowance(const SegmentBands& bands)
{
  std::array<std::vector<double>, 2> slopes;
  slopes[0].reserve(bands.depths.size());
  slopes[1].reserve(bands.depths.size());
  for (const BandReadings& b : bands.bands)
  {
    for (size_t k = 0; k + 1 < b.size; ++k)
    {
      const double lo = b.offsets[k], hi = b.offsets[k + 1], dx = hi - lo;
      const bool left = (hi < -0.25);
      const bool right = (lo > 0.25);
      if (dx < 0.5 || !(left || right))
        continue;
      slopes[right ? 1 : 0].push_back((b.depths[k + 1] - b.depths[k]) / dx);
    }
  }
  if (slopes[0].size() < 8 || slopes[1].size() < 8)
    return 0.0;
  return std::min(std::abs(medianInPlace(slopes[0])), std::abs(medianInPlace(slopes[1])));
}

struct EdgeDepth
{
  double depth_m = 0.0;
  bool far_seen = false;  // readings of a farther surface in the band: a discontinuity
  Eigen::Vector2d slope_m_per_px = Eigen::Vector2d::Zero();  // each side's depth slope across the edge
};

// Near cluster (the readings within a jump of the nearest one, the jump widened by the slant times the offset from
// it): inverse depth, affine in the offset on each side of the edge and continuous across it (a crease: both
// sides' slopes; an occluding contour: the near side only), evaluated at offset 0. Nothing when the nearest reading
// is too far from the edge or the fit is not positive.
std::optional<EdgeDepth> nearClusterDepth(const BandReadings& band, double jump, double slant_m_per_px,
                                          const DepthSamplerOptions& options)
{
  const double* offsets = band.offsets;
  const double* depths = band.depths;
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  double nearest_offset = std::numeric_limits<double>::infinity();
  double near_lo = std::numeric_limits<double>::infinity(), near_hi = 0.0;
  int left = 0, right = 0;
  EdgeDepth edge;
  for (size_t k = 0; k < band.size; ++k)
  {
    if (depths[k] > band.z_min + jump + slant_m_per_px * std::abs(offsets[k] - band.z_min_offset))
    {
      edge.far_seen = true;
      continue;
    }
    const double o = offsets[k];
    const Eigen::Vector3d row(1.0, std::min(o, 0.0), std::max(o, 0.0));
    ata += row * row.transpose();
    atb += row / depths[k];
    nearest_offset = std::min(nearest_offset, std::abs(o));
    near_lo = std::min(near_lo, depths[k]);
    near_hi = std::max(near_hi, depths[k]);
    left += o < -0.25;
    right += o > 0.25;
  }
  if (nearest_offset > options.max_extrapolation_px)
    return std::nullopt;
  // Keep the slope of a side only when it has two readings or more.
  for (int side = 1; side <= 2; ++side)
  {
    if ((side == 1 ? left : right) >= 2)
      continue;
    ata.row(side).setZero();
    ata.col(side).setZero();
    ata(side, side) = 1.0;
    atb(side) = 0.0;
  }
  const Eigen::Vector3d solution = ata.ldlt().solve(atb);
  const double inverse_depth = solution(0);
  if (!(inverse_depth > 0.0))
    return std::nullopt;
  // Never beyond the near cluster's readings by more than a jump.
  edge.depth_m = std::clamp(1.0 / inverse_depth, near_lo - jump, near_hi + jump);
  // dz / do = -z^2 dv / do on each side.
  edge.slope_m_per_px = -edge.depth_m * edge.depth_m * solution.tail<2>();
  return edge;
}

// Each side alone (readings at least half a pixel off the edge), its inverse depth extrapolated to the edge; NaN where
// a side has fewer than two readings or too little spread.
std::array<double, 2> oneSidedInverseDepths(const BandReadings& band)
{
  std::array<double, 2> sides = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  for (int side = 0; side < 2; ++side)
  {
    double sw = 0.0, so = 0.0, sv = 0.0, soo = 0.0, sov = 0.0;
    for (size_t k = 0; k < band.size; ++k)
    {
      const double o = band.offsets[k];
      if (side == 0 ? o > -0.5 : o < 0.5)
        continue;
      const double v = 1.0 / band.depths[k];
      sw += 1.0;
      so += o;
      sv += v;
      soo += o * o;
      sov += o * v;
    }
    const double var = soo - (sw > 0.0 ? so * so / sw : 0.0);
    if (sw >= 2.0 && var > 0.25)
    {
      const double slope = (sov - so * sv / sw) / var;
      sides[side] = (sv - slope * so) / sw;
    }
  }
  return sides;
}

// A step smaller than the per-sample jump (a door frame standing 1-2 cm off its wall, under depth noise of several mm)
// shows as a consistent difference of the two one-sided depths along the whole segment: then the edge belongs to the
// nearer side, and its samples take that side's depth.
void assignSmallStepToNearSide(const DepthSamplerOptions& options, std::vector<DepthSample>* out)
{
  const DepthStep step = measureDepthStep(*out);
  const double size_m = std::abs(step.left_nearer_by_m);
  if (!(step.samples > 0 && size_m > options.small_step_sigmas * step.sigma_m && size_m >= options.small_step_min_m))
    return;
  const int near = step.left_nearer_by_m > 0.0 ? 0 : 1;
  for (auto& sample : *out)
  {
    const double v = sample.side_inverse_depth(near);
    if (std::isfinite(v) && v > 0.0)
    {
      sample.depth_m = 1.0 / v;
      sample.discontinuity = true;
    }
  }
}
}  // namespace

DepthStep measureDepthStep(const std::vector<DepthSample>& samples)
{
  std::vector<double> diff;
  double z_sum = 0.0;
  for (const auto& sample : samples)
    if (sample.side_inverse_depth.allFinite())
    {
      diff.push_back(sample.side_inverse_depth(0) - sample.side_inverse_depth(1));
      z_sum += sample.depth_m;
    }
  DepthStep step;
  if (diff.size() < 8)
    return step;
  const double m = static_cast<double>(diff.size());
  double mean = 0.0;
  for (double x : diff)
    mean += x;
  mean /= m;
  double var = 0.0;
  for (double x : diff)
    var += (x - mean) * (x - mean);
  // Inverse depth -> depth at the segment's mean depth: dz = -z^2 dv, so a larger left inverse depth is nearer.
  const double z = z_sum / m;
  step.left_nearer_by_m = mean * z * z;
  step.sigma_m = std::sqrt(var / (m - 1.0) / m) * z * z;
  step.samples = static_cast<int>(diff.size());
  return step;
}

Expected<cv::Mat> depthToMeters(const cv::Mat& depth, double min_range_m, double max_range_m)
{
  if (depth.empty())
    return Error(ErrorCode::kInvalidInput, "the depth image is empty");
  if (depth.type() != CV_16UC1 && depth.type() != CV_32FC1)
    return Error(ErrorCode::kInvalidInput,
                 "depth must be 16UC1 (millimetres) or 32FC1 (metres), not " + cv::typeToString(depth.type()));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float lo = static_cast<float>(std::max(min_range_m, 0.0));
  const float hi = static_cast<float>(max_range_m);
  cv::Mat out(depth.size(), CV_32FC1);
  size_t valid = 0;
  for (int y = 0; y < depth.rows; ++y)
  {
    float* o = out.ptr<float>(y);
    if (depth.type() == CV_16UC1)
    {
      const uint16_t* d = depth.ptr<uint16_t>(y);
      for (int x = 0; x < depth.cols; ++x)
      {
        const float z = d[x] * 0.001f;
        const bool ok = d[x] != 0 && z >= lo && z <= hi;
        o[x] = ok ? z : nan;
        valid += ok;
      }
    }
    else
    {
      const float* d = depth.ptr<float>(y);
      for (int x = 0; x < depth.cols; ++x)
      {
        const float z = d[x];
        const bool ok = std::isfinite(z) && z > 0.0f && z >= lo && z <= hi;
        o[x] = ok ? z : nan;
        valid += ok;
      }
    }
  }
  if (valid == 0)
    return Error(
        ErrorCode::kNotEnoughData,
        "the depth image has no valid pixel (all zero or NaN" +
            std::string(min_range_m > 0.0 || std::isfinite(max_range_m) ? ", or outside the accepted range)" : ")"));
  return out;
}

std::vector<DepthSample> sampleDepthAlongSegment(const cv::Mat& depth_m, const Segment2d& segment,
                                                 const DepthSamplerOptions& options)
{
  std::vector<DepthSample> out;
  if (depth_m.empty() || depth_m.type() != CV_32FC1 || !segment.a.allFinite() || !segment.b.allFinite())
    return out;
  const double length = segment.length();
  if (!(length > 2.0 * options.end_margin_px) || !(options.step_px > 0.0))
    return out;
  const Eigen::Vector2d d = (segment.b - segment.a) / length;
  const Eigen::Vector2d n(-d.y(), d.x());
  const int band = std::max(1, options.band_px);
  const double usable = length - 2.0 * options.end_margin_px;
  const int count = static_cast<int>(std::floor(usable / options.step_px)) + 1;
  const double start = options.end_margin_px + 0.5 * (usable - (count - 1) * options.step_px);
  out.reserve(count);

  std::vector<double> positions(count);
  for (int i = 0; i < count; ++i)
    positions[i] = start + i * options.step_px;
  const SegmentBands bands = readBands(depth_m, segment.a, d, positions, band, options.registration_offset_px);
  const double slant = options.slant_allowance ? slantAllowance(bands) : 0.0;
  for (const BandReadings& r : bands.bands)
  {
    if (r.size == 0)
      continue;
    const double jump = std::max(options.jump_min_m, options.jump_ratio * r.z_min);
    // A side without any reading in the band (no return: a surface seen at a grazing angle, or a projector shadow):
    // when a surface nearer than the readings appears beyond the gap, the edge may belong to the unseen surface and
    // the readings are the background: no sample here.
    if (occludedBySurfaceBeyondGap(depth_m, r, n, band, options.gap_search_px, r.z_min - jump))
      continue;
    const std::optional<EdgeDepth> edge = nearClusterDepth(r, jump, slant, options);
    if (!edge)
      continue;
    DepthSample sample;
    // The readings measure the rays through their pixels moved by the registration offset: along the edge too.
    const double along = options.registration_offset_px.dot(d);
    sample.pixel = r.pixel + along * d;
    sample.t = (r.position + along) / length;
    sample.depth_m = edge->depth_m;
    sample.discontinuity = edge->far_seen;
    sample.depth_slope_m_per_px = edge->slope_m_per_px;
    if (!edge->far_seen)
    {
      const std::array<double, 2> sides = oneSidedInverseDepths(r);
      sample.side_inverse_depth = Eigen::Vector2d(sides[0], sides[1]);
    }
    out.push_back(sample);
  }
  if (options.small_step_sigmas > 0.0)
    assignSmallStepToNearSide(options, &out);
  return out;
}

}  // namespace insitu_calibration
