#include "insitu_calibration/lines/gradient_refiner.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/lines/segment_detector.h"
#include "insitu_calibration/robust_statistics.h"

namespace insitu_calibration
{
namespace
{
// Bilinear interpolation of a CV_32FC1 image (at least 2x2); false outside the image.
inline bool bilinear(const cv::Mat& img, double x, double y, double* value)
{
  if (!(x >= 0.0 && y >= 0.0 && x <= img.cols - 1 && y <= img.rows - 1))
    return false;
  const int x0 = std::min(static_cast<int>(x), img.cols - 2);
  const int y0 = std::min(static_cast<int>(y), img.rows - 2);
  const double fx = x - x0;
  const double fy = y - y0;
  const float* r0 = img.ptr<float>(y0);
  const float* r1 = img.ptr<float>(y0 + 1);
  *value = (1.0 - fy) * ((1.0 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1.0 - fx) * r1[x0] + fx * r1[x0 + 1]);
  return true;
}

inline Eigen::Vector2d perpendicular(const Eigen::Vector2d& d)
{
  return {-d.y(), d.x()};
}

Expected<cv::Mat> toGrayFloat(const cv::Mat& image)
{
  if (image.empty())
    return Error(ErrorCode::kInvalidInput, "the image is empty");
  cv::Mat out;
  try
  {
    switch (image.type())
    {
      case CV_16UC1:
        image.convertTo(out, CV_32F, 1.0 / 257.0);
        return out;
      case CV_32FC1: {
        double max_value = 0.0;
        cv::minMaxLoc(image, nullptr, &max_value);
        image.convertTo(out, CV_32F, max_value <= 1.0 ? 255.0 : 1.0);
        return out;
      }
      default: {
        auto gray = toGray8(image);
        if (!gray)
          return gray.error();
        gray->convertTo(out, CV_32F);
        return out;
      }
    }
  }
  catch (const cv::Exception& e)
  {
    return Error(ErrorCode::kInvalidInput, std::string("OpenCV could not convert the image: ") + e.what());
  }
}

struct WeightedLineFit
{
  double offset = 0.0;
  double slope = 0.0;
  bool ok = false;
};

// Weighted least squares of c = offset + slope * s over the samples with use[i].
WeightedLineFit fitOffsetSlope(const std::vector<double>& s, const std::vector<double>& c, const std::vector<double>& w,
                               const std::vector<char>& use)
{
  double sw = 0.0, ss = 0.0, sc = 0.0;
  for (size_t i = 0; i < s.size(); ++i)
  {
    if (!use[i])
      continue;
    sw += w[i];
    ss += w[i] * s[i];
    sc += w[i] * c[i];
  }
  WeightedLineFit fit;
  if (!(sw > 0.0))
    return fit;
  const double ms = ss / sw;
  const double mc = sc / sw;
  double sss = 0.0, ssc = 0.0;
  for (size_t i = 0; i < s.size(); ++i)
  {
    if (!use[i])
      continue;
    sss += w[i] * (s[i] - ms) * (s[i] - ms);
    ssc += w[i] * (s[i] - ms) * (c[i] - mc);
  }
  if (!(sss > 1e-9 * sw))
    return fit;
  fit.slope = ssc / sss;
  fit.offset = mc - fit.slope * ms;
  fit.ok = true;
  return fit;
}

// The line being fine-tuned (a point on it, its direction and normal) and its samples along it: s = 0 at the centre
// of the input segment (half-length h), `inside` between the input end points.
struct SampledLine
{
  Eigen::Vector2d p0, d, n;
  double h = 0.0;
  std::vector<double> s;
  std::vector<char> inside;
  size_t n_inside = 0;
  double s_abs_max = 0.0;

  Eigen::Vector2d at(size_t i) const { return p0 + s[i] * d; }
  // Shift by `offset` along the normal and tilt by `slope` (normal per unit of s).
  void move(double offset, double slope)
  {
    p0 += offset * n;
    d = (d + slope * n).normalized();
    n = perpendicular(d);
  }
};

Expected<SampledLine> sampleLine(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double extension_a_px,
                                 double extension_b_px, double step)
{
  SampledLine line;
  const double length = (b - a).norm();
  line.d = (b - a) / length;
  line.n = perpendicular(line.d);
  line.p0 = 0.5 * (a + b);
  line.h = 0.5 * length;
  const double s_begin = -line.h - std::max(0.0, extension_a_px);
  const double s_end = line.h + std::max(0.0, extension_b_px);
  const int count = static_cast<int>(std::floor((s_end - s_begin) / step)) + 1;
  const double s_offset = 0.5 * ((s_end - s_begin) - (count - 1) * step);
  for (int i = 0; i < count; ++i)
  {
    const double si = s_begin + s_offset + i * step;
    line.s.push_back(si);
    line.inside.push_back(std::abs(si) <= line.h + 1e-9);
  }
  line.n_inside = std::count(line.inside.begin(), line.inside.end(), 1);
  if (line.n_inside < 3)
    return Error(ErrorCode::kInvalidInput, "segment too short for the sample step");
  for (double si : line.s)
    line.s_abs_max = std::max(line.s_abs_max, std::abs(si));
  return line;
}

// |dI/dn| at offsets t_k = (k - half_steps) * 0.5 from each sample (a table of s.size() x (2 half_steps + 1), -1
// where the image ends), as cumulative sums along the line: a tilted line is a few runs of samples at one offset
// each, so its score is a sum over runs instead of over samples.
std::vector<double> cumulativeEdgeStrength(const cv::Mat& image, const SampledLine& line, int half_steps)
{
  const int table_size = 2 * half_steps + 1;
  const int grid_size = table_size + 2;  // intensities at t_k +- 0.5
  const std::vector<double>& s = line.s;
  std::vector<double> table(s.size() * table_size, -1.0);
  std::vector<double> intensity(grid_size);
  for (size_t i = 0; i < s.size(); ++i)
  {
    const Eigen::Vector2d q = line.at(i);
    bool ok = true;
    for (int m = 0; m < grid_size && ok; ++m)
    {
      const double t = (m - half_steps - 1) * 0.5;
      const Eigen::Vector2d x = q + t * line.n;
      ok = bilinear(image, x.x(), x.y(), &intensity[m]);
    }
    if (!ok)
      continue;
    for (int k = 0; k < table_size; ++k)
      table[i * table_size + k] = std::abs(intensity[k + 2] - intensity[k]);
  }
  std::vector<double> cumulative((s.size() + 1) * table_size, 0.0);
  for (size_t i = 0; i < s.size(); ++i)
    for (int k = 0; k < table_size; ++k)
      cumulative[(i + 1) * table_size + k] = cumulative[i * table_size + k] + std::max(0.0, table[i * table_size + k]);
  return cumulative;
}

// Coarse search, Eq. 8 literally: the sum of |dI/dn| on the line over a grid of offsets (0.5 px) and tilts; the line
// moves to the best.
void coarseSearch(const cv::Mat& image, double search_px, SampledLine* line)
{
  const std::vector<double>& s = line->s;
  const int half_steps = static_cast<int>(std::ceil(search_px / 0.5));
  const int table_size = 2 * half_steps + 1;  // t_k = (k - half_steps) * 0.5
  const std::vector<double> cumulative = cumulativeEdgeStrength(image, *line, half_steps);
  double best_score = -1.0;
  int best_k = half_steps;
  int best_q = 0;
  const int tilt_steps = 2 * half_steps;
  std::vector<std::pair<size_t, int>> runs;  // (first sample, shift), in order
  for (int q = -tilt_steps; q <= tilt_steps; ++q)
  {
    const double phi = q * 0.5 / std::max(1.0, line->s_abs_max);
    runs.clear();
    for (size_t i = 0; i < s.size(); ++i)
    {
      const int shift = static_cast<int>(std::lround(phi * s[i] / 0.5));
      if (runs.empty() || runs.back().second != shift)
        runs.emplace_back(i, shift);
    }
    for (int k = 0; k < table_size; ++k)
    {
      double score = 0.0;
      for (size_t r = 0; r < runs.size(); ++r)
      {
        const int kk = k + runs[r].second;
        if (kk < 0 || kk >= table_size)
          continue;
        const size_t end = r + 1 < runs.size() ? runs[r + 1].first : s.size();
        score += cumulative[end * table_size + kk] - cumulative[runs[r].first * table_size + kk];
      }
      // Prefer the input line on ties (flat regions).
      if (score > best_score + 1e-9 ||
          (std::abs(score - best_score) <= 1e-9 &&
           std::abs(k - half_steps) + std::abs(q) < std::abs(best_k - half_steps) + std::abs(best_q)))
      {
        best_score = score;
        best_k = k;
        best_q = q;
      }
    }
  }
  line->move((best_k - half_steps) * 0.5, best_q * 0.5 / std::max(1.0, line->s_abs_max));
}

// Per sample: the profile of dI/dn across the line and what the fit makes of it.
struct EdgeSamples
{
  explicit EdgeSamples(size_t n)
      : raw_weight(n), centroid(n), weight(n), flank(n), robust_weight(n, 0.0), final_residual(n, 0.0), valid(n), use(n)
  {}
  std::vector<double> raw_weight;      // the step across the window
  std::vector<double> centroid;        // of dI/dn, offset from the line
  std::vector<double> weight;          // the step with the edge's polarity
  std::vector<double> flank;           // outer minus inner steps: another edge inside the window
  std::vector<double> robust_weight;   // Tukey's biweight times the step
  std::vector<double> final_residual;  // centroid - fitted line, last iteration
  std::vector<char> valid;             // a profile with the edge's contrast
  std::vector<char> use;               // in the fit
};

// The summary of the sub-pixel fit.
struct SubpixelFit
{
  double polarity = 0.0;
  double support = 0.0;
  double residual_rms = 0.0;
  double contrast_sum = 0.0;
  double asymmetry = 0.0;
  int used = 0;
  int total_iterations = 0;
};

// The profiles across the line of one window (half-width w).
struct ProfileWindow
{
  ProfileWindow(double w, double profile_step)
      : count(std::max(3, static_cast<int>(std::floor(2.0 * w / profile_step + 1e-9)) + 1)),
        step(2.0 * w / (count - 1)),
        t0(-w),
        centroid_limit(w - std::min(0.5, 0.5 * w)),
        inner((count - 1) / 4)  // the flanks: |t| in [w / 2, w]
  {}
  int count;
  double step, t0, centroid_limit;
  int inner;
};

// A profile read as a thin line (a joint or seam narrower than the inner window, |t| < w / 2: no step across it):
// the grey levels above the straight baseline through the two flanks' means; the centroid of the part of that bump
// with its sign, the bump's peak as the signed weight (0 when the step between the flanks is larger than the peak:
// an edge, not a line), the step between the flanks as the flank.
void thinLineProfile(const std::vector<double>& intensity, const ProfileWindow& win, double* raw_weight,
                     double* centroid, double* flank)
{
  const int last = win.count - 1, inner = std::max(1, win.inner);
  double left = 0.0, right = 0.0;
  for (int j = 0; j <= inner; ++j)
  {
    left += intensity[j];
    right += intensity[last - j];
  }
  left /= inner + 1;
  right /= inner + 1;
  const double t_left = win.t0 + 0.5 * inner * win.step;
  const auto bump = [&](int j) {
    const double t = win.t0 + j * win.step;
    return intensity[j] - (left + (right - left) * (t - t_left) / (-2.0 * t_left));
  };
  double sum = 0.0;
  for (int j = inner + 1; j < last - inner; ++j)
    sum += bump(j);
  const double sign = sum >= 0.0 ? 1.0 : -1.0;
  double peak = 0.0, mass = 0.0, moment = 0.0;
  for (int j = inner + 1; j < last - inner; ++j)
  {
    const double r = std::max(0.0, sign * bump(j));
    peak = std::max(peak, r);
    mass += r;
    moment += (win.t0 + j * win.step) * r;
  }
  *flank = right - left;
  *raw_weight = (mass > 0.0 && std::abs(*flank) < peak) ? sign * peak : 0.0;
  *centroid = mass > 0.0 ? moment / mass : 0.0;
}

void sampleProfiles(const cv::Mat& image, const SampledLine& line, const ProfileWindow& win, bool thin_line,
                    EdgeSamples* e)
{
  std::vector<double> intensity(win.count);
  for (size_t i = 0; i < line.s.size(); ++i)
  {
    const Eigen::Vector2d q = line.at(i);
    bool ok = true;
    for (int j = 0; j < win.count && ok; ++j)
    {
      const Eigen::Vector2d x = q + (win.t0 + j * win.step) * line.n;
      ok = bilinear(image, x.x(), x.y(), &intensity[j]);
    }
    e->valid[i] = ok;
    if (!ok)
      continue;
    if (thin_line)
    {
      thinLineProfile(intensity, win, &e->raw_weight[i], &e->centroid[i], &e->flank[i]);
      continue;
    }
    double moment = 0.0;
    for (int j = 0; j + 1 < win.count; ++j)
      moment += (win.t0 + (j + 0.5) * win.step) * (intensity[j + 1] - intensity[j]);
    e->raw_weight[i] = intensity[win.count - 1] - intensity[0];
    e->centroid[i] = e->raw_weight[i] != 0.0 ? moment / e->raw_weight[i] : 0.0;
    e->flank[i] =
        (intensity[win.count - 1] - intensity[win.count - 1 - win.inner]) - (intensity[win.inner] - intensity[0]);
  }
}

double polarityOf(const SampledLine& line, const EdgeSamples& e)
{
  double sum = 0.0;
  for (size_t i = 0; i < line.s.size(); ++i)
    if (e.valid[i] && line.inside[i])
      sum += e.raw_weight[i];
  return sum >= 0.0 ? 1.0 : -1.0;
}

// Samples with the edge's contrast and polarity are valid (they support the edge); of those, the ones whose window
// also holds another edge (near corners, parallel neighbours) see a different step and are left out of the fit. The
// typical step is fixed at the first iteration of each window. Returns the number of supporting samples inside.
size_t selectEdgeSamples(const RefinerOptions& o, const SampledLine& line, const ProfileWindow& win, double polarity,
                         bool first_iteration, double* typical_contrast, EdgeSamples* e)
{
  size_t supported = 0;
  for (size_t i = 0; i < line.s.size(); ++i)
  {
    e->weight[i] = polarity * e->raw_weight[i];
    e->valid[i] = e->valid[i] && e->weight[i] >= o.min_contrast && std::abs(e->centroid[i]) <= win.centroid_limit;
    e->use[i] = e->valid[i];
    if (e->valid[i] && line.inside[i])
      ++supported;
  }
  if (o.contrast_tolerance > 0.0)
  {
    if (first_iteration)
    {
      std::vector<double> contrasts;
      for (size_t i = 0; i < line.s.size(); ++i)
        if (e->valid[i] && line.inside[i])
          contrasts.push_back(e->weight[i]);
      *typical_contrast = middleValue(contrasts);
    }
    for (size_t i = 0; i < line.s.size(); ++i)
      if (e->use[i] && std::abs(e->weight[i] - *typical_contrast) > o.contrast_tolerance * *typical_contrast)
        e->use[i] = 0;
  }
  return supported;
}

// Robust weights (Tukey's biweight, scale from the MAD) on the residuals about the current line (after the first
// iteration: the previous fit) or, in the first iteration, about a plain weighted fit: iteratively reweighted least
// squares of the same objective, so the iteration converges instead of switching between subsets of samples.
// Returns the number of samples kept.
Expected<int> reweightRobustly(const RefinerOptions& o, const SampledLine& line, bool first_iteration, EdgeSamples* e)
{
  const std::vector<double>& s = line.s;
  std::vector<double> residual(s.size(), 0.0);
  if (first_iteration)
  {
    const WeightedLineFit first = fitOffsetSlope(s, e->centroid, e->weight, e->use);
    if (!first.ok)
      return Error(ErrorCode::kDegenerate, "the edge samples do not determine a line");
    for (size_t i = 0; i < s.size(); ++i)
      residual[i] = e->centroid[i] - first.offset - first.slope * s[i];
  }
  else
  {
    residual = e->centroid;
  }
  std::vector<double> abs_residuals;
  for (size_t i = 0; i < s.size(); ++i)
    if (e->use[i])
      abs_residuals.push_back(std::abs(residual[i]));
  const double scale = std::max(o.outlier_px / 3.0, robustSigma(abs_residuals));
  const double cutoff = 4.685 * scale;
  int used = 0;
  for (size_t i = 0; i < s.size(); ++i)
  {
    e->robust_weight[i] = 0.0;
    if (!e->use[i] || std::abs(residual[i]) >= cutoff)
    {
      e->use[i] = 0;
      continue;
    }
    const double u = residual[i] / cutoff;
    e->robust_weight[i] = e->weight[i] * (1.0 - u * u) * (1.0 - u * u);
    ++used;
  }
  if (used < 3)
    return Error(ErrorCode::kNotEnoughData, "too few edge samples after outlier rejection");
  return used;
}

// The weighted fit of the kept samples' centroids; its RMS, contrast and flank asymmetry go into `fit`.
Expected<WeightedLineFit> fitCentroids(const SampledLine& line, EdgeSamples* e, SubpixelFit* fit)
{
  const std::vector<double>& s = line.s;
  const WeightedLineFit f = fitOffsetSlope(s, e->centroid, e->robust_weight, e->use);
  if (!f.ok)
    return Error(ErrorCode::kDegenerate, "the edge samples do not determine a line");
  double r2 = 0.0, wsum = 0.0, flank_sum = 0.0;
  fit->contrast_sum = 0.0;
  for (size_t i = 0; i < s.size(); ++i)
  {
    if (!e->use[i])
      continue;
    const double r = e->centroid[i] - f.offset - f.slope * s[i];
    r2 += e->weight[i] * r * r;
    wsum += e->weight[i];
    fit->contrast_sum += e->weight[i];
    flank_sum += fit->polarity * e->flank[i];
  }
  fit->residual_rms = std::sqrt(r2 / wsum);
  fit->asymmetry = flank_sum / wsum;
  for (size_t i = 0; i < s.size(); ++i)
    e->final_residual[i] = e->centroid[i] - f.offset - f.slope * s[i];
  return f;
}

// Iterates the sub-pixel fit in one window (half-width w) until the line moves less than the convergence limit.
Status fitInWindow(const cv::Mat& image, const RefinerOptions& o, double w, bool first_stage, bool last_stage,
                   bool thin_line, SampledLine* line, EdgeSamples* e, SubpixelFit* fit)
{
  // A stage followed by another only has to bring the line close: coarser profiles, looser convergence.
  const ProfileWindow win(w, last_stage ? o.profile_step_px : std::max(o.profile_step_px, 0.5));
  const double convergence = last_stage ? o.convergence_px : std::max(o.convergence_px, 0.02);
  double typical_contrast = 0.0;
  for (int iteration = 1; iteration <= o.max_iterations; ++iteration)
  {
    sampleProfiles(image, *line, win, thin_line, e);
    if (first_stage && iteration == 1)
      fit->polarity = polarityOf(*line, *e);
    const size_t supported = selectEdgeSamples(o, *line, win, fit->polarity, iteration == 1, &typical_contrast, e);
    fit->support = static_cast<double>(supported) / static_cast<double>(line->n_inside);
    if (fit->support < o.min_support || supported < 3)
      return Error(ErrorCode::kNotEnoughData, "no edge under the segment: " + std::to_string(supported) + " of " +
                                                  std::to_string(line->n_inside) + " samples see a contrast of at " +
                                                  "least " + std::to_string(o.min_contrast) + " grey levels");
    const Expected<int> used = reweightRobustly(o, *line, iteration == 1, e);
    if (!used)
      return used.error();
    fit->used = *used;
    const Expected<WeightedLineFit> f = fitCentroids(*line, e, fit);
    if (!f)
      return f.error();
    line->move(f->offset, f->slope);
    if (std::abs(f->offset) + std::abs(f->slope) * line->s_abs_max < convergence)
    {
      fit->total_iterations += iteration;
      return Success();
    }
  }
  return Error(ErrorCode::kNoSolution, "fine-tuning did not converge in " + std::to_string(o.max_iterations) +
                                           " iterations (the segment may span a corner or two edges)");
}

// Sub-pixel: centroids of dI/dn in a window of half-width w about the line, weighted line fit, iterate; first with
// half_width_px (capture range), then with polish_half_width_px (another edge 1.5-3 px away no longer pulls the
// centroids). The last window's flanks tell whether another edge remains inside it. A part without an edge is
// fitted again, from the searched line, as a thin line (RefinerOptions::thin_lines) in its own window.
Status fitSubpixel(const cv::Mat& image, const RefinerOptions& o, SampledLine* line, EdgeSamples* samples,
                   SubpixelFit* fit, bool* thin_line)
{
  std::vector<double> windows = {o.half_width_px};
  if (o.polish_half_width_px > 0.0 && o.polish_half_width_px < o.half_width_px)
    windows.push_back(o.polish_half_width_px);
  const SampledLine searched = *line;
  for (size_t stage = 0; stage < windows.size(); ++stage)
  {
    const Status fitted =
        fitInWindow(image, o, windows[stage], stage == 0, stage + 1 == windows.size(), false, line, samples, fit);
    if (fitted)
      continue;
    if (!o.thin_lines || stage > 0 || fitted.error().code() == ErrorCode::kInvalidInput)
      return fitted;
    *line = searched;
    *fit = SubpixelFit();
    if (!fitInWindow(image, o, o.thin_line_half_width_px, true, true, true, line, samples, fit))
      return fitted;
    *thin_line = true;
    return Success();
  }
  if (o.max_asymmetry > 0.0 && std::abs(fit->asymmetry) > o.max_asymmetry)
    return Error(ErrorCode::kDegenerate, "another edge lies within " + std::to_string(windows.back()) +
                                             " px of the line (flank asymmetry " + std::to_string(fit->asymmetry) +
                                             ")");
  return Success();
}

// Where two edges meet at a small angle or offset along the part: the sample between them and which side is shorter.
struct EdgeBreak
{
  bool found = false;
  double s_break = 0.0;
  bool a_shorter = false;
};

// Two lines, one on each side of some sample, fit the centroids much better than one (F statistic of the 2 extra
// parameters), and the two differ by more than end_tolerance_px at the end of the shorter side.
EdgeBreak findEdgeBreak(const RefinerOptions& o, const SampledLine& line, const EdgeSamples& e)
{
  const std::vector<double>& s = line.s;
  std::vector<size_t> idx;
  for (size_t i = 0; i < s.size(); ++i)
    if (e.valid[i])
      idx.push_back(i);
  const size_t m = idx.size();
  const size_t min_side = static_cast<size_t>(std::ceil(o.min_break_px / o.sample_step_px));
  if (m < 2 * min_side + 4)
    return {};
  // Prefix sums of 1, s, c, s^2, s c, c^2 (c: centroid about the final line).
  std::vector<std::array<double, 6>> sums(m + 1, std::array<double, 6>{});
  for (size_t k = 0; k < m; ++k)
  {
    const double x = s[idx[k]], y = e.final_residual[idx[k]];
    const std::array<double, 6> v = {1.0, x, y, x * x, x * y, y * y};
    for (int j = 0; j < 6; ++j)
      sums[k + 1][j] = sums[k][j] + v[j];
  }
  // Least-squares line y = p + q x of samples [from, to): residual sum of squares, p, q.
  auto fitRange = [&](size_t from, size_t to, double* p, double* q) {
    std::array<double, 6> t;
    for (int j = 0; j < 6; ++j)
      t[j] = sums[to][j] - sums[from][j];
    const double n = t[0], mx = t[1] / n, my = t[2] / n;
    const double sxx = t[3] - n * mx * mx, sxy = t[4] - n * mx * my, syy = t[5] - n * my * my;
    *q = sxx > 1e-12 ? sxy / sxx : 0.0;
    *p = my - *q * mx;
    return std::max(0.0, syy - *q * sxy);
  };
  double p_all, q_all;
  const double ssr_one = fitRange(0, m, &p_all, &q_all);
  double best_ssr = ssr_one;
  size_t best_k = 0;
  for (size_t k = min_side; k + min_side <= m; ++k)
  {
    double p1, q1, p2, q2;
    const double ssr = fitRange(0, k, &p1, &q1) + fitRange(k, m, &p2, &q2);
    if (ssr < best_ssr)
    {
      best_ssr = ssr;
      best_k = k;
    }
  }
  if (best_k == 0)
    return {};
  double p1, q1, p2, q2;
  fitRange(0, best_k, &p1, &q1);
  fitRange(best_k, m, &p2, &q2);
  const double sigma2 = std::max(best_ssr / static_cast<double>(m - 4), 1e-6);
  const double f = 0.5 * (ssr_one - best_ssr) / sigma2;
  // The two sides' lines at the outer end of the shorter side.
  EdgeBreak result;
  result.a_shorter = best_k < m - best_k;
  const double x_end = result.a_shorter ? s[idx.front()] : s[idx.back()];
  const double apart = std::abs((p1 + q1 * x_end) - (p2 + q2 * x_end));
  result.found = f > o.min_break_f && apart > o.end_tolerance_px;
  result.s_break = 0.5 * (s[idx[best_k - 1]] + s[idx[best_k]]);
  return result;
}

// Where the edge does not reach an end point (it ends, or a nearly collinear edge 0.5-2 px aside takes over: the
// robust fit follows the longer one), the samples there lie off the line or see no edge: the length of such a run at
// the end (from a or from b), up to the first few consecutive samples on the line.
double offLineRun(const RefinerOptions& o, const SampledLine& line, const EdgeSamples& e, double tolerance, bool from_a)
{
  const std::vector<double>& s = line.s;
  const double h = line.h;
  const int on_run = std::max(1, static_cast<int>(std::ceil(o.min_end_run_px / o.sample_step_px)));
  const int first = from_a ? 0 : static_cast<int>(s.size()) - 1;
  const int dir = from_a ? 1 : -1;
  int on = 0;
  double last_off = std::numeric_limits<double>::quiet_NaN(), first_on = last_off;
  for (int i = first; i >= 0 && i < static_cast<int>(s.size()); i += dir)
  {
    if (!line.inside[i])
      continue;
    if (e.valid[i] && std::abs(e.final_residual[i]) <= tolerance)
    {
      if (on++ == 0)
        first_on = s[i];
      if (on >= on_run)
        break;
    }
    else
    {
      on = 0;
      last_off = s[i];
    }
  }
  if (std::isnan(last_off))
    return 0.0;
  const double cut = std::isnan(first_on) || on < on_run ? (from_a ? h : -h) : 0.5 * (last_off + first_on);
  const double off = from_a ? cut + h : h - cut;
  return off >= o.min_end_run_px ? off : 0.0;
}

// The off-line runs at both ends (RefinerOptions::end_tolerance_px).
void measureOffLineEnds(const RefinerOptions& o, const SampledLine& line, const EdgeSamples& e, RefinedSegment* r)
{
  std::vector<double> abs_residuals;
  for (size_t i = 0; i < line.s.size(); ++i)
    if (e.use[i])
      abs_residuals.push_back(std::abs(e.final_residual[i]));
  const double tolerance = std::max(o.end_tolerance_px, 3.0 * kMadToSigma * middleValue(abs_residuals));
  r->off_a_px = offLineRun(o, line, e, tolerance, true);
  r->off_b_px = offLineRun(o, line, e, tolerance, false);
}

// A segment refined on one side of a break, extended back to the input's other end point (projected on the line).
RefinedSegment extendOverBreak(RefinedSegment r, const Eigen::Vector2d& a, const Eigen::Vector2d& b, bool a_off,
                               double off_px)
{
  const Eigen::Vector2d dk = (r.b - r.a).normalized();
  if (a_off)
  {
    r.a = r.a + (a - r.a).dot(dk) * dk;
    r.off_a_px = std::max(r.off_a_px, off_px);
  }
  else
  {
    r.b = r.a + (b - r.a).dot(dk) * dk;
    r.off_b_px = std::max(r.off_b_px, off_px);
  }
  r.shift_px = std::max((r.a - a).norm(), (r.b - b).norm());
  return r;
}

}  // namespace

Expected<LineRefiner> LineRefiner::create(const cv::Mat& image, const RefinerOptions& options)
{
  if (!(options.half_width_px >= 1.0) || !(options.profile_step_px > 0.0) ||
      !(options.profile_step_px <= options.half_width_px) || !(options.sample_step_px > 0.0) ||
      !(options.search_px >= 0.0) || !(options.extension_px >= 0.0) || options.max_iterations < 1 ||
      !(options.min_support >= 0.0 && options.min_support <= 1.0) ||
      (options.thin_lines && !(options.thin_line_half_width_px >= 1.0)))
    return Error(ErrorCode::kInvalidInput,
                 "invalid fine-tuning options (need half_width_px >= 1 and with thin lines thin_line_half_width_px "
                 ">= 1, "
                 "0 < profile_step_px <= half_width_px, sample_step_px > 0, "
                 "search_px >= 0, extension_px >= 0, max_iterations >= 1, "
                 "min_support in [0, 1])");
  auto gray = toGrayFloat(image);
  if (!gray)
    return gray.error();
  if (gray->cols < 2 || gray->rows < 2)
    return Error(ErrorCode::kInvalidInput, "the image is smaller than 2x2 pixels");
  if (options.smoothing_sigma_px > 0.0)
  {
    try
    {
      cv::GaussianBlur(*gray, *gray, cv::Size(), options.smoothing_sigma_px, options.smoothing_sigma_px,
                       cv::BORDER_REPLICATE);
    }
    catch (const cv::Exception& e)
    {
      return Error(ErrorCode::kInvalidInput, std::string("OpenCV could not smooth the image: ") + e.what());
    }
  }
  return LineRefiner(std::move(*gray), options);
}

Expected<RefinedSegment> LineRefiner::refineSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const
{
  return refineSegment(a, b, options_.extension_px, options_.extension_px);
}

Expected<RefinedSegment> LineRefiner::refineSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                                    double extension_a_px, double extension_b_px) const
{
  return refineSegment(a, b, extension_a_px, extension_b_px, true);
}

Expected<RefinedSegment> LineRefiner::refineSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                                    double extension_a_px, double extension_b_px,
                                                    bool find_breaks) const
{
  const RefinerOptions& o = options_;
  if (!a.allFinite() || !b.allFinite() || !std::isfinite(extension_a_px) || !std::isfinite(extension_b_px))
    return Error(ErrorCode::kInvalidInput, "segment end points must be finite");
  if (!((b - a).norm() >= 2.0))
    return Error(ErrorCode::kInvalidInput, "segment shorter than 2 px");
  Expected<SampledLine> sampled = sampleLine(a, b, extension_a_px, extension_b_px, o.sample_step_px);
  if (!sampled)
    return sampled.error();
  SampledLine& line = *sampled;

  // 1. Coarse search (Eq. 8 on a grid).
  if (o.search_px > 0.0)
    coarseSearch(image_, o.search_px, &line);

  // 2. Sub-pixel (fitSubpixel).
  EdgeSamples samples(line.s.size());
  SubpixelFit fit;
  bool thin_line = false;
  if (const Status fitted = fitSubpixel(image_, o, &line, &samples, &fit, &thin_line); !fitted)
    return fitted.error();

  // 3. A part across the junction of two edges meeting at a small angle or offset is fitted between them: it is
  //    fine-tuned again on the longer side only, and the shorter side is reported off the line (off_a_px /
  //    off_b_px), for the caller to split or trim there.
  if (find_breaks && o.end_tolerance_px > 0.0 && o.min_break_px > 0.0)
  {
    const EdgeBreak brk = findEdgeBreak(o, line, samples);
    const Eigen::Vector2d cut = line.p0 + brk.s_break * line.d;
    if (brk.found && brk.a_shorter && brk.s_break < line.h - 2.0)
    {
      auto kept = refineSegment(cut, b, 0.0, extension_b_px, false);  // keep [break, b]: a lies off the line
      if (kept)
        return extendOverBreak(*kept, a, b, true, brk.s_break + line.h);
    }
    else if (brk.found && !brk.a_shorter && brk.s_break > -line.h + 2.0)
    {
      auto kept = refineSegment(a, cut, extension_a_px, 0.0, false);
      if (kept)
        return extendOverBreak(*kept, a, b, false, line.h - brk.s_break);
    }
  }

  RefinedSegment result;
  if (o.end_tolerance_px > 0.0)
    measureOffLineEnds(o, line, samples, &result);
  result.line = Eigen::Vector3d(line.n.x(), line.n.y(), -line.n.dot(line.p0));
  result.a = line.p0 + (a - line.p0).dot(line.d) * line.d;
  result.b = line.p0 + (b - line.p0).dot(line.d) * line.d;
  result.contrast = fit.contrast_sum / std::max(1, fit.used);
  result.support = fit.support;
  result.residual_px = fit.residual_rms;
  result.shift_px = std::max((result.a - a).norm(), (result.b - b).norm());
  result.iterations = fit.total_iterations;
  result.asymmetry = fit.asymmetry;
  result.samples = fit.used;
  result.thin_line = thin_line;
  return result;
}

Expected<RefinedPolyline> LineRefiner::refinePolyline(const std::vector<Eigen::Vector2d>& points) const
{
  if (points.size() < 2)
    return Error(ErrorCode::kInvalidInput, "a polyline needs at least 2 points");
  const size_t parts = points.size() - 1;
  RefinedPolyline out;
  out.parts.resize(parts);
  std::vector<char> ok(parts, 0);
  for (size_t i = 0; i < parts; ++i)
  {
    const double ext_a = i == 0 ? options_.extension_px : 0.0;
    const double ext_b = i + 1 == parts ? options_.extension_px : 0.0;
    auto part = refineSegment(points[i], points[i + 1], ext_a, ext_b);
    if (part)
    {
      out.parts[i] = *part;
      ok[i] = 1;
    }
    else
    {
      ++out.failed_parts;
      out.parts[i].a = points[i];
      out.parts[i].b = points[i + 1];
    }
  }
  if (out.failed_parts == static_cast<int>(parts))
    return Error(ErrorCode::kNotEnoughData, "no part of the polyline lies on an edge");
  out.points.resize(points.size());
  for (size_t k = 0; k < points.size(); ++k)
  {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    int votes = 0;
    if (k > 0 && ok[k - 1])
    {
      sum += out.parts[k - 1].b;
      ++votes;
    }
    if (k < parts && ok[k])
    {
      sum += out.parts[k].a;
      ++votes;
    }
    out.points[k] = votes ? Eigen::Vector2d(sum / votes) : points[k];
    out.max_shift_px = std::max(out.max_shift_px, (out.points[k] - points[k]).norm());
  }
  return out;
}

}  // namespace insitu_calibration
