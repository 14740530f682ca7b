#include "insitu_calibration/lines/image_lines.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <optional>
#include <string>

#include "insitu_calibration/cpu_time.h"
#include "insitu_calibration/io/parameter_range.h"

namespace insitu_calibration
{
namespace
{

// Drops failed parts at the two ends of a refined polyline (the edge is shorter than the detection there).
void trimFailedEnds(ImageLine& line)
{
  while (!line.parts.empty() && line.parts.front().samples == 0)
  {
    line.parts.erase(line.parts.begin());
    line.points.erase(line.points.begin());
  }
  while (!line.parts.empty() && line.parts.back().samples == 0)
  {
    line.parts.pop_back();
    line.points.pop_back();
  }
}

// Moves the two end points of a line inwards past the samples of its end parts that lie off the fine-tuned line
// (RefinedSegment::off_a_px, off_b_px): there the edge ends, or a nearly collinear one continues 0.5-2 px aside and
// the line, fitted to the longer edge, would run beside it. Each end part keeps at least 2 px.
void trimOffEnds(ImageLine& line)
{
  if (line.parts.empty())
    return;
  auto move = [](Eigen::Vector2d& end, const Eigen::Vector2d& other, double off) {
    const Eigen::Vector2d d = other - end;
    const double length = d.norm();
    if (off > 0.0 && length > 2.0)
      end += std::min(off, length - 2.0) / length * d;
  };
  const size_t last = line.points.size() - 1;
  if (line.parts.size() == 1)
  {
    // Both ends on one part: the part keeps at least 2 px between them.
    const double length = (line.points[1] - line.points[0]).norm();
    const double off_a = line.parts[0].off_a_px, off_b = line.parts[0].off_b_px;
    const double scale = off_a + off_b > length - 2.0 ? std::max(0.0, length - 2.0) / (off_a + off_b) : 1.0;
    const Eigen::Vector2d d = (line.points[1] - line.points[0]) / std::max(length, 1e-9);
    line.points[0] += scale * off_a * d;
    line.points[1] -= scale * off_b * d;
    line.parts[0].a = line.points[0];
    line.parts[0].b = line.points[1];
    return;
  }
  move(line.points[0], line.points[1], line.parts.front().off_a_px);
  move(line.points[last], line.points[last - 1], line.parts.back().off_b_px);
  line.parts.front().a = line.points.front();
  line.parts.back().b = line.points.back();
}

// Where two fine-tuned parts of a polyline lie on different edges: the parts [cuts[c], cuts[c + 1]) of each piece.
// Two successive parts that found the edge (possibly with failed parts between them) disagree when
//  - their lines are more than split_gap_px apart at the vertex they share (or, across failed parts, in the middle
//    of the failed span), beyond what the detected polyline's own bend explains there; or
//  - (adjacent parts) more than split_kink_px apart at the far end of either part, beyond the detected bend: they
//    meet at an angle, e.g. where an edge runs into another one at a few degrees (0.5 px over a 75 px part: 0.4°;
//    the fine-tuned direction of such a part is good to ~0.05°).
std::vector<size_t> findCuts(const std::vector<Eigen::Vector2d>& detected, const std::vector<RefinedSegment>& parts,
                             const ImageLineOptions& options)
{
  std::vector<size_t> cuts = {0};
  // Signed distance of p from the fine-tuned line of part i and from the detected part i, normals oriented alike.
  auto fine = [&](size_t i, const Eigen::Vector2d& p) { return parts[i].line.dot(Eigen::Vector3d(p.x(), p.y(), 1.0)); };
  auto coarse = [&](size_t i, const Eigen::Vector2d& p) {
    const Eigen::Vector2d d = (detected[i + 1] - detected[i]).normalized();
    Eigen::Vector2d n(-d.y(), d.x());
    if (n.dot(parts[i].line.head<2>()) < 0.0)
      n = -n;
    return n.dot(p - detected[i]);
  };
  // How far apart parts i and j are at p, beyond the detected polyline's bend there.
  auto apart = [&](size_t i, size_t j, const Eigen::Vector2d& p) {
    const double sign = parts[i].line.head<2>().dot(parts[j].line.head<2>()) < 0.0 ? -1.0 : 1.0;
    return std::abs((fine(i, p) - sign * fine(j, p)) - (coarse(i, p) - sign * coarse(j, p)));
  };
  size_t previous = parts.size();  // last part that found the edge
  for (size_t k = 0; k < parts.size(); ++k)
  {
    if (parts[k].samples == 0)
      continue;
    if (previous < parts.size())
    {
      const Eigen::Vector2d middle = 0.5 * (detected[previous + 1] + detected[k]);
      bool cut = options.split_gap_px > 0.0 && apart(previous, k, middle) > options.split_gap_px;
      if (!cut && previous + 1 == k && options.split_kink_px > 0.0)
        cut = std::max(apart(previous, k, detected[previous]), apart(previous, k, detected[k + 1])) >
              options.split_kink_px;
      if (cut)
        cuts.push_back(previous + 1);
    }
    previous = k;
  }
  cuts.push_back(parts.size());
  return cuts;
}

double polylineLength(const std::vector<Eigen::Vector2d>& points)
{
  double length = 0.0;
  for (size_t k = 0; k + 1 < points.size(); ++k)
    length += (points[k + 1] - points[k]).norm();
  return length;
}

// The piece of a fine-tuned polyline between cut vertices first and last (parts [first, last), vertices [first,
// last]), trimmed where it leaves its edge; nothing when too little is left. piece/pieces: its place among them.
std::optional<ImageLine> pieceOf(const ImagePolyline& polyline, const RefinedPolyline& refined, size_t first,
                                 size_t last, size_t piece, size_t pieces, const ImageLineOptions& options,
                                 ImageLineStats& st)
{
  ImageLine line;
  line.detected.assign(polyline.points.begin() + first, polyline.points.begin() + last + 1);
  line.points.assign(refined.points.begin() + first, refined.points.begin() + last + 1);
  line.parts.assign(refined.parts.begin() + first, refined.parts.begin() + last);
  line.fragments = polyline.fragments;
  // A cut vertex belongs to the part on its side only.
  if (piece > 0)
    line.points.front() = line.parts.front().a;
  if (piece + 1 < pieces)
    line.points.back() = line.parts.back().b;
  trimFailedEnds(line);
  if (line.points.size() < 2)
    return std::nullopt;
  const bool trimmed = line.parts.front().off_a_px > 0.0 || line.parts.back().off_b_px > 0.0;
  trimOffEnds(line);
  st.trimmed += trimmed;
  const bool changed = pieces > 1 || trimmed;
  line.length_px = changed ? polylineLength(line.points) : polyline.length_px;
  if (changed && line.length_px < options.merge.min_length_px)
    return std::nullopt;
  double contrast = 0.0;
  int ok_parts = 0;
  for (const auto& p : line.parts)
    if (p.samples > 0)
    {
      contrast += p.contrast;
      ++ok_parts;
    }
  line.contrast = ok_parts ? contrast / ok_parts : 0.0;
  return line;
}

// One merged polyline fine-tuned (Eq. 8) and cut where two fine-tuned parts disagree: its pieces, appended to lines.
void refineIntoLines(const LineRefiner& refiner, const ImagePolyline& polyline, const ImageLineOptions& options,
                     ImageLineStats& st, std::vector<ImageLine>* lines)
{
  auto refined = refiner.refinePolyline(polyline.points);
  if (!refined)
  {
    ++st.rejected;
    return;
  }
  const int parts = static_cast<int>(refined->parts.size());
  if (parts - refined->failed_parts < options.min_part_support * parts)
  {
    ++st.rejected;
    return;
  }
  const std::vector<size_t> cuts = findCuts(polyline.points, refined->parts, options);
  st.splits += cuts.size() > 2;
  for (size_t c = 0; c + 1 < cuts.size(); ++c)
  {
    auto line = pieceOf(polyline, *refined, cuts[c], cuts[c + 1], c, cuts.size() - 1, options, st);
    if (line)
      lines->push_back(std::move(*line));
    else
      ++st.rejected;
  }
}

double distanceToPolyline(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& p)
{
  double best = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k + 1 < points.size(); ++k)
  {
    const Eigen::Vector2d ab = points[k + 1] - points[k];
    const double t = std::clamp((p - points[k]).dot(ab) / std::max(ab.squaredNorm(), 1e-12), 0.0, 1.0);
    best = std::min(best, (points[k] + t * ab - p).norm());
  }
  return best;
}

// The share of a's length (sampled every px) within tolerance_px of b.
double shareOn(const ImageLine& a, const ImageLine& b, double tolerance_px)
{
  int near = 0, total = 0;
  for (size_t k = 0; k + 1 < a.points.size(); ++k)
  {
    const Eigen::Vector2d ab = a.points[k + 1] - a.points[k];
    const int steps = std::max(1, static_cast<int>(ab.norm()));
    for (int i = 0; i < steps; ++i, ++total)
      near += distanceToPolyline(b.points, a.points[k] + (i + 0.5) / steps * ab) <= tolerance_px;
  }
  return total > 0 ? static_cast<double>(near) / total : 0.0;
}

// Why no line came out, for the caller's message.
std::string noLinesNote(const ImageLineStats& st, size_t polylines, const ImageLineOptions& options)
{
  if (st.segments.empty())
    return "no line segment of at least " + formatParameterValue(options.detector.min_length_px) + " px detected";
  if (polylines == 0)
    return std::to_string(st.segments.size()) + " segments, but no merged line of at least " +
           formatParameterValue(options.merge.min_length_px) + " px";
  return "fine-tuning found no edge under any of the " + std::to_string(polylines) + " lines";
}
}  // namespace

Expected<std::vector<ImageLine>> extractImageLines(const cv::Mat& image, const DivisionModel& distortion,
                                                   const ImageLineOptions& options, ImageLineStats* stats)
{
  ImageLineStats local;
  ImageLineStats& st = stats ? *stats : local;
  st = ImageLineStats();
  if (image.empty())
    return Error(ErrorCode::kInvalidInput, "the image is empty");
  if (!std::isfinite(distortion.lambda) || !distortion.center.allFinite())
    return Error(ErrorCode::kInvalidInput, "the distortion model is not finite");

  double t = threadCpuMs();
  SegmentDetector detector(options.detector);
  auto segments = detector.detect(image);
  if (!segments)
    return segments.error();
  st.segments = std::move(*segments);
  st.detect_ms = cpuMsSince(t);

  t = threadCpuMs();
  const std::vector<ImagePolyline> polylines = mergeSegments(st.segments, distortion, options.merge);
  st.polylines = static_cast<int>(polylines.size());
  st.merge_ms = cpuMsSince(t);

  t = threadCpuMs();
  std::vector<ImageLine> lines;
  if (!polylines.empty())
  {
    auto refiner = LineRefiner::create(image, options.refiner);
    if (!refiner)
      return refiner.error();
    for (const auto& polyline : polylines)
      refineIntoLines(*refiner, polyline, options, st, &lines);
    st.duplicates = dropDuplicateThinLines(options.duplicate_thin_px, &lines);
  }
  st.refine_ms = cpuMsSince(t);
  st.lines = static_cast<int>(lines.size());
  if (lines.empty())
    st.note = noLinesNote(st, polylines.size(), options);
  return lines;
}

Expected<std::vector<ImageLine>> extractImageLines(const cv::Mat& image, const CameraModel& camera,
                                                   const ImageLineOptions& options, ImageLineStats* stats)
{
  return extractImageLines(image, camera.distortion(), options, stats);
}

int dropDuplicateThinLines(double tolerance_px, std::vector<ImageLine>* lines)
{
  // Without thin lines (the default) there is nothing to drop: no pairwise test on every image.
  if (!(tolerance_px > 0.0) || std::none_of(lines->begin(), lines->end(), [](const ImageLine& l) { return l.thin(); }))
    return 0;
  std::vector<size_t> order(lines->size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t i, size_t j) { return (*lines)[i].length_px > (*lines)[j].length_px; });
  std::vector<char> keep(lines->size(), 1);
  for (size_t oi = 0; oi < order.size(); ++oi)
  {
    const ImageLine& shorter = (*lines)[order[oi]];
    for (size_t oj = 0; oj < oi && keep[order[oi]]; ++oj)
    {
      const ImageLine& longer = (*lines)[order[oj]];
      if (keep[order[oj]] && (shorter.thin() || longer.thin()) && shareOn(shorter, longer, tolerance_px) >= 0.5)
        keep[order[oi]] = 0;
    }
  }
  std::vector<ImageLine> kept;
  for (size_t i = 0; i < lines->size(); ++i)
    if (keep[i])
      kept.push_back(std::move((*lines)[i]));
  const int dropped = static_cast<int>(lines->size() - kept.size());
  *lines = std::move(kept);
  return dropped;
}

double refineImageLines(const LineRefiner& refiner, std::vector<ImageLine>& lines)
{
  double max_shift = 0.0;
  for (auto& line : lines)
  {
    auto refined = refiner.refinePolyline(line.points);
    if (!refined)
      continue;
    line.points = refined->points;
    line.parts = refined->parts;
    max_shift = std::max(max_shift, refined->max_shift_px);
  }
  return max_shift;
}

}  // namespace insitu_calibration
