#include "insitu_calibration/survey/image_explanation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/map/floor_lines.h"
#include "insitu_calibration/matching/line_matcher.h"

namespace insitu_calibration
{
namespace
{
double median(std::vector<double> v)
{
  if (v.empty())
    return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

float bilinear(const cv::Mat& m, double x, double y)
{
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= m.cols || y0 + 1 >= m.rows)
    return 0.0f;
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  return (1 - fy) * ((1 - fx) * m.at<float>(y0, x0) + fx * m.at<float>(y0, x0 + 1)) +
         fy * ((1 - fx) * m.at<float>(y0 + 1, x0) + fx * m.at<float>(y0 + 1, x0 + 1));
}

struct Gradients
{
  cv::Mat gx, gy;  // grey levels per px
};

Gradients gradients(const cv::Mat& image)
{
  cv::Mat grey;
  if (image.channels() == 3)
    cv::cvtColor(image, grey, cv::COLOR_RGB2GRAY);
  else
    grey = image;
  grey.convertTo(grey, CV_32F);
  Gradients g;
  cv::Sobel(grey, g.gx, CV_32F, 1, 0, 3, 1.0 / 8.0);
  cv::Sobel(grey, g.gy, CV_32F, 0, 1, 3, 1.0 / 8.0);
  return g;
}

// Whether an edge across the normal n lies within 1 px of p.
bool onEdge(const Gradients& g, const Eigen::Vector2d& p, const Eigen::Vector2d& n, const ImageExplanationOptions& o)
{
  for (const double s : {-1.0, -0.5, 0.0, 0.5, 1.0})
  {
    const Eigen::Vector2d q = p + s * n;
    const Eigen::Vector2d grad(bilinear(g.gx, q.x(), q.y()), bilinear(g.gy, q.x(), q.y()));
    const double across = std::abs(grad.dot(n));
    if (across >= o.min_gradient && across >= o.min_alignment * grad.norm())
      return true;
  }
  return false;
}

// Calls visit(pixel, unit normal, map point) for each sample of one map line's projection (sample_step_px apart, 3 px
// inside the image); false when the projection is too short to assess.
template <typename Visit>
bool forEachSample(const CameraModel& camera, const Segment3d& line, const std::pair<double, double>& interval,
                   int width, int height, const ImageExplanationOptions& o, Visit visit)
{
  const Eigen::Vector3d a = line.a + interval.first * (line.b - line.a);
  const Eigen::Vector3d b = line.a + interval.second * (line.b - line.a);
  const auto pa = camera.project(a), pb = camera.project(b);
  if (!pa || !pb || (*pb - *pa).norm() < o.min_line_length_px)
    return false;
  const int n = std::min(600, static_cast<int>((*pb - *pa).norm() / o.sample_step_px) + 1);
  for (int k = 0; k < n; ++k)
  {
    const double t = (k + 0.5) / n;
    const auto p = camera.project(a + t * (b - a));
    const auto q = camera.project(a + std::min(1.0, t + 0.5 / n) * (b - a));
    const auto r = camera.project(a + std::max(0.0, t - 0.5 / n) * (b - a));
    if (!p || !q || !r || (*q - *r).norm() < 1e-6)
      continue;
    const Eigen::Vector2d d = (*q - *r).normalized(), normal(-d.y(), d.x());
    if (p->x() < 3 || p->y() < 3 || p->x() > width - 4 || p->y() > height - 4)
      continue;
    visit(*p, normal, a + t * (b - a));
  }
  return true;
}

using PixelsAndNormals = std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>;

// The mean gradient across the line (grey levels per px, signed along the normals), over samples, at an offset
// along their normals, with its standard error.
struct MeanGradient
{
  double mean = 0.0, standard_error = 0.0;
};

MeanGradient meanGradientAcross(const Gradients& g, const PixelsAndNormals& at, double offset)
{
  double sum = 0.0, sum_squares = 0.0;
  for (const auto& [p, n] : at)
  {
    const Eigen::Vector2d q = p + offset * n;
    const double across = Eigen::Vector2d(bilinear(g.gx, q.x(), q.y()), bilinear(g.gy, q.x(), q.y())).dot(n);
    sum += across;
    sum_squares += across * across;
  }
  const double n = static_cast<double>(at.size());
  MeanGradient out;
  out.mean = sum / n;
  out.standard_error = std::sqrt(std::max(0.0, sum_squares / n - out.mean * out.mean) / std::max(1.0, n - 1.0));
  return out;
}

// Whether the samples (pixel, unit normal; one line's, normals all to one side) lie on a faint edge: a step across
// the line, averaged along it, as ImageExplanationOptions::faint_edge_gradient describes.
bool onFaintEdge(const Gradients& g, const PixelsAndNormals& at, const ImageExplanationOptions& o)
{
  if (!(o.faint_edge_gradient > 0.0) || at.size() < std::max<size_t>(2, o.faint_edge_min_samples))
    return false;
  MeanGradient best;
  for (const double s : {-1.0, -0.5, 0.0, 0.5, 1.0})
  {
    const MeanGradient m = meanGradientAcross(g, at, s);
    if (std::abs(m.mean) > std::abs(best.mean))
      best = m;
  }
  const double beside = std::max(std::abs(meanGradientAcross(g, at, o.chance_offset_px).mean),
                                 std::abs(meanGradientAcross(g, at, -o.chance_offset_px).mean));
  const double step = std::abs(best.mean);
  return step >= o.faint_edge_gradient && step >= o.faint_edge_significance * best.standard_error &&
         step >= o.faint_edge_beside_ratio * beside;
}

// One map line's samples and how many of them have an edge on the line and beside it (both sides counted).
struct LineSupport
{
  size_t samples = 0, on = 0, beside = 0;
  // The sides beside the samples that measure the chance level (places clear of the other map lines' projections),
  // of them those on an edge, and those not chance_offset_px from the line.
  size_t chance_sides = 0, chance_hits = 0, chance_moved = 0;
  size_t faint = 0;     // of on: found by the averaged step along the line (onFaintEdge)
  size_t left_out = 0;  // plain floor samples left out one by one (not in on, beside: they have no edge)
  size_t amid = 0;      // samples with no chance place on either side (not in on, beside, isolated, left_out)
  size_t isolated = 0, isolated_on = 0;  // samples with no edge beside on either side, and of those on an edge
};

// One map line as the final check sees it: its counts, and (when asked for) its samples for the report's overlay.
struct AssessedLine
{
  LineSupport support;
  EdgeSamples samples;
  std::vector<bool> amid;  // with samples kept and the map lines' bands: per sample, amid other map lines
  bool is_floor = true;    // its plain samples are counted as floor samples (else as texture samples)
};

// The image as the check sees it: its gradients, and where the map lines in view project (a band of
// ImageExplanationOptions::chance_mapped_radius_px about each; empty when off): an edge beside a line there is
// another map line's, explained by the camera, not met by chance.
struct CheckedView
{
  Gradients gradients;
  cv::Mat mapped;  // CV_8U, non-zero on a map line's projection
  bool onMapLine(const Eigen::Vector2d& q) const
  {
    const int u = static_cast<int>(std::lround(q.x())), v = static_cast<int>(std::lround(q.y()));
    return !mapped.empty() && u >= 0 && v >= 0 && u < mapped.cols && v < mapped.rows && mapped.at<uchar>(v, u) != 0;
  }
};

cv::Mat mapLineBands(const CameraModel& camera, const std::vector<Segment3d>& lines,
                     const std::vector<std::pair<double, double>>& intervals, int width, int height, double radius_px)
{
  cv::Mat mask = cv::Mat::zeros(height, width, CV_8U);
  const int thickness = std::max(1, static_cast<int>(std::lround(2.0 * radius_px)));
  for (size_t i = 0; i < lines.size(); ++i)
  {
    const Eigen::Vector3d a = lines[i].a + intervals[i].first * (lines[i].b - lines[i].a);
    const Eigen::Vector3d b = lines[i].a + intervals[i].second * (lines[i].b - lines[i].a);
    const auto pa = camera.project(a), pb = camera.project(b);
    const double length = pa && pb ? (*pb - *pa).norm() : 100.0;
    const int n = std::clamp(static_cast<int>(length / 4.0), 1, 500);  // distortion bends long projections
    std::optional<Eigen::Vector2d> previous;
    for (int k = 0; k <= n; ++k)
    {
      const auto p = camera.project(a + (static_cast<double>(k) / n) * (b - a));
      if (p && previous)
        cv::line(mask, cv::Point2d(previous->x(), previous->y()), cv::Point2d(p->x(), p->y()), cv::Scalar(255),
                 thickness, cv::LINE_8);
      previous = p;
    }
  }
  return mask;
}

// Where beside the sample p (along sign * normal) the chance level is measured: chance_offset_px from the line, or,
// where another map line projects near there, the nearest offset up to 1.5 chance_offset_px clear of every map
// line's band (its own included); none when there is no such place (a texture finer than the bands).
std::optional<Eigen::Vector2d> chancePlace(const CheckedView& view, const Eigen::Vector2d& p,
                                           const Eigen::Vector2d& normal, double sign, const ImageExplanationOptions& o)
{
  const double farthest = 1.5 * o.chance_offset_px;
  for (int k = 0; k <= 2 * static_cast<int>(std::ceil(farthest)); ++k)
  {
    const double offset = o.chance_offset_px + ((k % 2) ? -0.5 : 0.5) * ((k + 1) / 2);
    if (offset <= 0.0 || offset > farthest)
      continue;
    const Eigen::Vector2d q = p + sign * offset * normal;
    if (!view.onMapLine(q))
      return q;
  }
  return std::nullopt;
}

// Keeps the sample for the report's overlay (left_out: not counted there).
void keepSample(const Eigen::Vector2d& p, const Eigen::Vector3d& point, bool on, bool left_out, bool amid,
                bool with_flags, AssessedLine& a)
{
  a.samples.points.push_back(p);
  a.samples.map_points.push_back(point);
  a.samples.on_edge.push_back(on);
  if (with_flags)
    a.samples.left_out.push_back(left_out || amid);
  a.amid.push_back(amid);
}

// One sample's edge test on the line and beside it, counted into a (kept in a.samples with keep_samples).
// leave_out_plain: a sample with no edge on it or beside it is left out (plain floor there). A sample with no chance
// place on either side (amid other map lines' projections) is left out. Returns whether the sample counts and is
// plain (no edge on it nor beside it).
bool assessSample(const CheckedView& view, const Eigen::Vector2d& p, const Eigen::Vector2d& normal,
                  const Eigen::Vector3d& point, const ImageExplanationOptions& o, bool keep_samples,
                  bool leave_out_plain, AssessedLine& a)
{
  const Gradients& g = view.gradients;
  const bool on = onEdge(g, p, normal, o);
  const Eigen::Vector2d sides[2] = {p + o.chance_offset_px * normal, p - o.chance_offset_px * normal};
  std::optional<Eigen::Vector2d> places[2] = {sides[0], sides[1]};
  if (!view.mapped.empty())
    for (int side = 0; side < 2; ++side)
      places[side] = chancePlace(view, p, normal, side == 0 ? 1.0 : -1.0, o);
  const bool amid = o.chance_needs_both_sides ? !places[0] || !places[1] : !places[0] && !places[1];
  const bool side_on_edge[2] = {onEdge(g, sides[0], normal, o), onEdge(g, sides[1], normal, o)};
  const int beside = (side_on_edge[0] ? 1 : 0) + (side_on_edge[1] ? 1 : 0);
  const bool left_out = !amid && leave_out_plain && !on && beside == 0;
  ++a.support.samples;
  if (keep_samples)
    keepSample(p, point, on, left_out, amid, leave_out_plain || !view.mapped.empty(), a);
  if (amid)
  {
    ++a.support.amid;
    return false;
  }
  a.support.on += on ? 1 : 0;
  a.support.beside += beside;
  a.support.left_out += left_out ? 1 : 0;
  for (int side = 0; side < 2 && !left_out; ++side)
    if (places[side])
    {
      const bool moved = *places[side] != sides[side];
      ++a.support.chance_sides;
      a.support.chance_hits += (moved ? onEdge(g, *places[side], normal, o) : side_on_edge[side]) ? 1 : 0;
      a.support.chance_moved += moved ? 1 : 0;
    }
  if (!leave_out_plain && beside == 0)  // where plain samples are left out, the isolated ones all have an edge
  {
    ++a.support.isolated;
    a.support.isolated_on += on ? 1 : 0;
  }
  return !on && beside == 0;
}

// The line's plain samples (pixel, normal, index in a.samples) count as on an edge when, averaged, they lie on a
// faint one (onFaintEdge). Only for lines whose plain samples count (they are all isolated samples then).
void countFaintEdge(const Gradients& g, const PixelsAndNormals& plain, const std::vector<size_t>& plain_index,
                    const ImageExplanationOptions& o, AssessedLine& a)
{
  if (!onFaintEdge(g, plain, o))
    return;
  a.support.on += plain.size();
  a.support.faint += plain.size();
  a.support.isolated_on += plain.size();
  for (const size_t k : plain_index)
    if (k < a.samples.on_edge.size())
      a.samples.on_edge[k] = true;
}

// None when the projection is too short to assess.
std::optional<AssessedLine> assessLine(const CheckedView& view, const CameraModel& camera, const Segment3d& line,
                                       const std::pair<double, double>& interval, int width, int height,
                                       const ImageExplanationOptions& o, bool keep_samples, bool leave_out_plain)
{
  AssessedLine a;
  PixelsAndNormals plain;
  std::vector<size_t> plain_index;
  const bool assessed =
      forEachSample(camera, line, interval, width, height, o,
                    [&](const Eigen::Vector2d& p, const Eigen::Vector2d& normal, const Eigen::Vector3d& point) {
                      const size_t index = a.samples.points.size();
                      if (assessSample(view, p, normal, point, o, keep_samples, leave_out_plain, a) && !leave_out_plain)
                      {
                        plain.emplace_back(p, normal);
                        plain_index.push_back(index);
                      }
                    });
  if (!assessed)
    return std::nullopt;
  countFaintEdge(view.gradients, plain, plain_index, o, a);
  return a;
}

// A line on the ceiling the survey measured, when the ceiling rule is on.
bool onCeiling(const Segment3d& line, const ImageExplanationOptions& o)
{
  return o.plain_ceiling && o.ceiling_height_m &&
         segmentOnFloor(line.a, line.b, *o.ceiling_height_m, o.floor_tolerance_m);
}

// Per line in view, whether the plain-floor test applies to it: a floor line, or a ceiling line inside a grid of
// parallel ceiling lines (tile or panel joints; a ceiling's border with a wall, a grid on one side only, is not one).
std::vector<bool> plainTestedLines(const std::vector<Segment3d>& lines, const ImageExplanationOptions& o)
{
  std::vector<bool> tested(lines.size(), false);
  if (!o.leave_out_plain_floor)
    return tested;
  std::vector<Segment3d> ceiling;
  std::vector<size_t> ceiling_index;
  for (size_t i = 0; i < lines.size(); ++i)
  {
    tested[i] = segmentOnFloor(lines[i].a, lines[i].b, o.floor_height_m, o.floor_tolerance_m);
    if (!tested[i] && onCeiling(lines[i], o))
    {
      ceiling.push_back(lines[i]);
      ceiling_index.push_back(i);
    }
  }
  const std::vector<bool> grid = textureLines(ceiling, o.ceiling_grid);
  for (size_t k = 0; k < ceiling.size(); ++k)
    tested[ceiling_index[k]] = grid[k];
  return tested;
}

// A floor line whose image shows hardly any edge on it or beside it: texture this camera does not resolve. With
// plain_floor_by_sample, one whose every sample was left out; a texture line too.
bool onPlainFloor(bool floor_line, const LineSupport& s, const ImageExplanationOptions& o)
{
  if (s.samples == 0)
    return false;
  if (s.left_out > 0 && s.left_out + s.amid == s.samples)
    return true;
  if (!floor_line || o.plain_floor_by_sample)
    return false;
  const double n = static_cast<double>(s.samples);
  return s.on < o.plain_floor_on_edge * n && 0.5 * s.beside < o.plain_floor_beside * n;
}

// Every sample of the line counts again (too few other lines to judge the camera on).
void countWhole(AssessedLine& a)
{
  a.samples.counted = true;
  a.support.left_out = 0;
  a.samples.left_out.clear();
  if (std::find(a.amid.begin(), a.amid.end(), true) != a.amid.end())
    a.samples.left_out = a.amid;  // samples amid other map lines stay out
}

// The map lines in view that the overlay test assesses (projections long enough, with a sample inside the image),
// each with samples.counted set: false for a plain-floor line left out (when enough others remain); with
// plain_floor_by_sample the floor lines' plain samples are left out one by one.
std::vector<AssessedLine> assessOverlay(const cv::Mat& image, const CameraModel& camera, int width, int height,
                                        const std::vector<Segment3d>& map_lines, const ImageExplanationOptions& options,
                                        bool keep_samples)
{
  CheckedView view;
  view.gradients = gradients(image);
  std::vector<Segment3d> in_view;
  std::vector<std::pair<double, double>> intervals;
  for (const auto& line : map_lines)
    if (const auto interval = visibleInterval(camera, line, width, height))
    {
      in_view.push_back(line);
      intervals.push_back(*interval);
    }
  if (options.chance_mapped_radius_px > 0.0)
    view.mapped = mapLineBands(camera, in_view, intervals, width, height, options.chance_mapped_radius_px);
  const std::vector<bool> texture = textureLines(in_view, options.texture);
  const std::vector<bool> plain_tested = plainTestedLines(in_view, options);
  std::vector<AssessedLine> lines;
  size_t plain_count = 0;
  for (size_t i = 0; i < in_view.size(); ++i)
  {
    const Segment3d& line = in_view[i];
    const bool floor_by_sample = options.plain_floor_by_sample && plain_tested[i];
    auto assessed = assessLine(view, camera, line, intervals[i], width, height, options, keep_samples,
                               floor_by_sample || texture[i]);
    if (!assessed || assessed->support.samples == 0)  // not assessed, or only at the border
      continue;
    assessed->is_floor = floor_by_sample;
    assessed->samples.counted = !onPlainFloor(plain_tested[i], assessed->support, options);
    plain_count += assessed->samples.counted ? 0 : 1;
    lines.push_back(std::move(*assessed));
  }
  if (lines.size() - plain_count < std::max<size_t>(1, options.min_lines_without_plain_floor))
    for (AssessedLine& a : lines)  // too few others to judge the camera on: every line counts
      countWhole(a);
  return lines;
}

// The overlay agreement and its chance level over the lines that count.
void measureOverlay(const std::vector<AssessedLine>& lines, const ImageExplanationOptions& o, ImageExplanation& out)
{
  size_t on = 0, beside = 0, isolated_on = 0, chance_sides = 0, chance_hits = 0, chance_moved = 0;
  for (const AssessedLine& a : lines)
  {
    if (!a.samples.counted)
    {
      ++out.plain_lines;
      continue;
    }
    out.amid_samples += a.support.amid;
    ++out.map_lines;
    out.samples += a.support.samples - a.support.left_out - a.support.amid;
    (a.is_floor ? out.plain_floor_samples : out.plain_texture_samples) += a.support.left_out;
    on += a.support.on;
    beside += a.support.beside;
    out.isolated_samples += a.support.isolated;
    isolated_on += a.support.isolated_on;
    out.faint_samples += a.support.faint;
    chance_sides += a.support.chance_sides;
    chance_moved += a.support.chance_moved;
    chance_hits += a.support.chance_hits;
  }
  if (out.samples > 0)
  {
    out.overlay_agreement = static_cast<double>(on) / out.samples;
    out.overlay_chance = 0.5 * static_cast<double>(beside) / out.samples;
  }
  if (o.chance_mapped_radius_px > 0.0 && chance_sides >= std::max<size_t>(1, o.min_chance_sides))
  {
    out.overlay_chance = static_cast<double>(chance_hits) / chance_sides;
    out.chance_places_moved = chance_moved;
    out.chance_places_none = 2 * out.samples - std::min(2 * out.samples, chance_sides);
  }
  if (out.isolated_samples > 0)
    out.isolated_agreement = static_cast<double>(isolated_on) / out.isolated_samples;
}

// "43 %".
std::string percent(double share)
{
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.0f %%", 100.0 * share);
  return buffer;
}
}  // namespace

std::string ImageExplanation::describe() const
{
  char buffer[320];
  std::snprintf(
      buffer, sizeof(buffer),
      "%zu map lines in view, %.0f %% of their length on image edges (%.0f %% 4 px beside them, excess %.2f; %.0f %% "
      "where nothing is beside them); %zu matched lines: median residual %.3f px, held out %.3f px",
      map_lines, 100.0 * overlay_agreement, 100.0 * overlay_chance, overlayExcess(), 100.0 * isolated_agreement,
      matched_lines, median_rms_px, median_heldout_px);
  std::string out = buffer;
  if (plain_lines > 0)
    out += "; " + std::to_string(plain_lines) + " floor, ceiling or texture lines left out where the image looks plain";
  if (plain_floor_samples > 0)
    out += "; " + std::to_string(plain_floor_samples) +
           " samples of other floor or ceiling lines left out where it looks plain";
  if (faint_samples > 0)
    out += "; " + std::to_string(faint_samples) + " samples on faint edges (a step averaged along their line)";
  if (amid_samples > 0)
    out += "; " + std::to_string(amid_samples) +
           " samples amid other map lines left out (no place beside them to measure the chance level)";
  if (chance_places_moved + chance_places_none > 0)
    out += "; chance measured clear of other map lines: " + std::to_string(chance_places_moved) +
           " places beside moved, " + std::to_string(chance_places_none) + " with none";
  if (plain_texture_samples > 0)
    out += "; " + std::to_string(plain_texture_samples) +
           " samples of wall texture (brick, tile or panel joints) left out where the image is plain";
  return out;
}

ImageExplanation explainImage(const cv::Mat& image, const CameraModel& camera, int width, int height,
                              const std::vector<Segment3d>& map_lines, const RefinementResult* refinement,
                              const ImageExplanationOptions& options, std::vector<EdgeSamples>* checked_lines)
{
  ImageExplanation out;
  if (checked_lines)
    checked_lines->clear();
  if (!image.empty())
  {
    out.image_checked = true;
    std::vector<AssessedLine> lines =
        assessOverlay(image, camera, width, height, map_lines, options, checked_lines != nullptr);
    measureOverlay(lines, options, out);
    if (checked_lines)
      for (AssessedLine& a : lines)
        checked_lines->push_back(std::move(a.samples));
  }
  if (refinement)
  {
    std::vector<double> rms, heldout;
    for (size_t k = 0; k < refinement->line_loo_rms_px.size() && k < refinement->line_rms_px.size(); ++k)
      if (std::isfinite(refinement->line_rms_px[k]) && !std::isnan(refinement->line_loo_rms_px[k]))
      {
        rms.push_back(refinement->line_rms_px[k]);
        heldout.push_back(refinement->line_loo_rms_px[k]);
      }
    out.matched_lines = rms.size();
    out.median_rms_px = median(rms);
    out.median_heldout_px = median(heldout);
  }
  return out;
}

std::vector<EdgeSamples> sampleEdgeSupport(const cv::Mat& image, const CameraModel& camera, int width, int height,
                                           const std::vector<Segment3d>& map_lines,
                                           const ImageExplanationOptions& options)
{
  std::vector<EdgeSamples> out;
  explainImage(image, camera, width, height, map_lines, nullptr, options, &out);
  return out;
}

Status acceptExplanation(const ImageExplanation& e, const ImageExplanationOptions& o)
{
  const std::string numbers = " (" + e.describe() + ")";
  const bool overlay_tested = o.min_overlay_agreement > 0.0 || o.min_overlay_excess > 0.0;
  if (overlay_tested && e.image_checked && e.samples == 0)
    return Error(ErrorCode::kNoSolution,
                 "the camera does not explain the image: it sees none of the map lines long enough to check" + numbers +
                     " (the surfaces the survey measured hide them from it, or they lie outside its view); the "
                     "matches are probably wrong: check the prior, or survey more of the view");
  if (o.min_overlay_agreement > 0.0 && e.samples > 0 && e.overlay_agreement < o.min_overlay_agreement)
    return Error(ErrorCode::kNoSolution,
                 "the camera does not explain the image: too few of the map lines it sees fall on image edges" +
                     numbers + "; the matches are probably wrong: check the prior, or survey more of the view");
  if (o.min_overlay_excess > 0.0 && e.samples > 0 && e.overlayExcess() < o.min_overlay_excess)
    return Error(ErrorCode::kNoSolution,
                 "the camera does not explain the image: the map lines it sees meet image edges hardly more often "
                 "than lines beside them" +
                     numbers + "; the matches are probably wrong: check the prior, or survey more of the view");
  if (o.min_isolated_agreement > 0.0 && e.isolated_samples >= std::max<size_t>(1, o.min_isolated_samples) &&
      e.isolated_agreement < o.min_isolated_agreement)
    return Error(ErrorCode::kNoSolution,
                 "the camera does not explain the image: where the image beside them is plain, the map lines it sees "
                 "mostly miss image edges (" +
                     percent(e.isolated_agreement) + " of " + std::to_string(e.isolated_samples) + " samples on one)" +
                     numbers + "; the matches are probably wrong: check the prior, or survey more of the view");
  if (o.max_heldout_ratio > 0.0 && e.matched_lines > 0 && e.median_heldout_px > o.max_heldout_ratio * e.median_rms_px)
    return Error(ErrorCode::kNoSolution, "the camera predicts its own lines badly when each is held out" + numbers +
                                             "; a few lines decide it: survey more of the camera's view");
  return Success{};
}

}  // namespace insitu_calibration
