// bench_lines: time (and accuracy) of line extraction on rendered frames: 640x480 RGB-D frames of a robot survey
// (detection, 2D fine-tuning, depth sampling, RANSAC, line-map merge) and 1920x1080 fixed-camera images (detection,
// merging, fine-tuning), for the FLD and LSD detectors. Single-threaded.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "command_line.h"
#include "insitu_calibration/lines/depth_registration.h"
#include "insitu_calibration/lines/image_lines.h"
#include "insitu_calibration/lines/line_evaluation.h"
#include "insitu_calibration/lines/line_map.h"
#include "insitu_calibration/lines/rgbd_lines.h"
#include "insitu_calibration/simulation/line_frames.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "insitu_calibration/test_support/line_scene.h"
#include "insitu_calibration/test_support/synthetic_lines.h"
#include "insitu_calibration/geometry/optical_frame.h"

#include "insitu_calibration/cpu_time.h"
namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const char* kUsage = R"(Usage: bench_lines [--world FILE] [--duration S] [--rate HZ] [--frames N] [--fixed-frames N]
                   [--rgb-noise SIGMA] [--min-support N] [--detector fld|lsd|both] [--seed S] [--repeat R] [--verbose]
                   [--end-tolerance PX] [--split-kink PX] [--min-break PX]
       bench_lines --room [--frames N] [--fixed N] [--detector fld|lsd|both] [--seed S] [--repeat R] [--save DIR]

Times line extraction on one core (cv::setNumThreads(1); CPU time of the thread, so other load on the machine
inflates it little), best of R runs per frame (rendering is not timed), and measures its accuracy against the true
3D edges:
  - per 640x480 RGB-D frame: detection, 2D fine-tuning, depth sampling, RANSAC + refinement, line-map merge
    (goal < 15 ms per frame); the 3D line error against the distance from the sensor; the line map's error;
  - per fixed-camera image (every camera of the world, 1920x1080 included): detection, merging of fragments,
    fine-tuning (Eq. 8) (goal < 100 ms per 1920x1080 image); the RMS distance of the lines to the true curved edges
    (true K, lambda and pose) before and after fine-tuning, with lambda = 0 (first pass) and the true lambda.

Simulator frames (default): the survey simulator (docs/simulator.md) on a world file.
  --world FILE        default config/worlds/waiting_room.yaml
  --duration S        survey length, default 40 (the default survey: 200 RGB-D frames)
  --rate HZ           RGB-D frames per second, default 5
  --frames N          only the first N RGB-D frames
  --fixed-frames N    noisy frames per fixed camera, default 2
  --rgb-noise SIGMA   override the world's Xtion RGB noise (grey levels; the worlds have none)
  --min-support N     map lines used for calibration (the survey's min_map_support), default 2
  --detector          default fld
  --seed S            simulator noise seed, default 1
  --end-tolerance PX  fixed cameras: RefinerOptions::end_tolerance_px (0: ends not trimmed, no part broken), default 0.3
  --split-kink PX     fixed cameras: ImageLineOptions::split_kink_px (0: no split at kinks), default 0.5
  --min-break PX      fixed cameras: RefinerOptions::min_break_px (0: parts not tested for a break), default 8
--room: the synthetic room of the test support's line_scene.h (flat-shaded quads drawn by the simulator's renderer;
1920x1080 fixed images f = 1100 px with the corner moved 20 px; --frames default 30, --fixed default 2, --detector
default both, --save DIR writes the rendered images).
--verbose: every 2D line worse than 0.15 px (0.1 px with --room) after fine-tuning or on no true edge, every 3D line
worse than 1 cm or 0.5 deg or on no true edge, and every map line more than 5 mm off its edge.
)";

struct Series
{
  std::vector<double> v;
  void add(double x) { v.push_back(x); }
  double mean() const
  {
    double s = 0.0;
    for (double x : v)
      s += x;
    return v.empty() ? 0.0 : s / v.size();
  }
  double quantile(double q) const
  {
    if (v.empty())
      return std::nan("");
    std::vector<double> s = v;
    std::sort(s.begin(), s.end());
    return s[std::min(s.size() - 1, static_cast<size_t>(std::floor(q * (s.size() - 1) + 0.5)))];
  }
  double median() const { return quantile(0.5); }
  double max() const { return v.empty() ? std::nan("") : *std::max_element(v.begin(), v.end()); }
  double rms() const
  {
    double s = 0.0;
    for (double x : v)
      s += x * x;
    return v.empty() ? std::nan("") : std::sqrt(s / v.size());
  }
};

Eigen::Isometry3d lookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = *ic::opticalRotationLookingAlong(target - position);
  t.translation() = position;
  return t;
}

void printRow(const char* name, const Series& s, const char* unit = "ms")
{
  std::printf("  %-28s mean %7.2f  median %7.2f  p90 %7.2f  max %7.2f %s\n", name, s.mean(), s.median(),
              s.quantile(0.9), s.max(), unit);
}

// The fastest of `repeat` runs of an extraction (CPU time of the thread), with its stage times and its result.
template <typename Stats, typename Value>
struct Timed
{
  Value value;
  Stats stats;
  double ms = std::numeric_limits<double>::infinity();
};

// `extract(Stats*)` returns an Expected<Value>; its first error ends the runs.
template <typename Stats, typename Extract>
auto bestOf(int repeat, Extract&& extract)
{
  using Value = std::decay_t<decltype(*extract(static_cast<Stats*>(nullptr)))>;
  Timed<Stats, Value> best;
  for (int r = 0; r < repeat; ++r)
  {
    Stats stats;
    const double t = ic::threadCpuMs();
    auto result = extract(&stats);
    const double ms = ic::cpuMsSince(t);
    if (!result)
      return ic::Expected<Timed<Stats, Value>>(result.error());
    if (ms < best.ms)
    {
      best.ms = ms;
      best.stats = stats;
      best.value = std::move(*result);
    }
  }
  return ic::Expected<Timed<Stats, Value>>(std::move(best));
}

// ------------------------------------------------------------------------------------------ --room (synthetic)
// The robot circles the room's centre; the camera (0.9 m high) looks outwards at the walls, slightly down.
std::vector<ic::RgbdFrame> renderRoomSurvey(const ic::LineScene& scene, int frames, ic::CommandLine& cl,
                                            std::mt19937& rng)
{
  std::vector<ic::RgbdFrame> survey;
  for (int i = 0; i < frames; ++i)
  {
    const double phi = 2.0 * M_PI * i / std::max(1, frames);
    const Eigen::Vector3d position(3.0 + 1.2 * std::cos(phi), 2.5 + 0.9 * std::sin(phi), 0.9);
    const double yaw = phi + 0.6 * std::sin(3.0 * phi);
    const Eigen::Vector3d target = position + Eigen::Vector3d(std::cos(yaw), std::sin(yaw), -0.15);
    ic::RgbdFrame f;
    f.camera.width = 640;
    f.camera.height = 480;
    f.camera.intrinsics.fx = f.camera.intrinsics.fy = 570.3;
    f.camera.intrinsics.cx = 319.5;
    f.camera.intrinsics.cy = 239.5;
    f.T_map_camera = lookAt(position, target);
    f.stamp = i / 30.0;
    const ic::CameraModel model(f.camera.intrinsics, ic::DivisionModel{0.0, f.camera.intrinsics.principalPoint()},
                                ic::CameraPose::fromWorldFromCamera(f.T_map_camera));
    ic::LineSceneRenderOptions render;
    render.supersampling = 4;
    render.noise_sigma = 2.0;
    render.blur_sigma_px = 0.5;
    const cv::Mat grey = ic::renderGrey(scene, model, 640, 480, render, rng);
    cv::cvtColor(grey, f.rgb, cv::COLOR_GRAY2BGR);
    f.depth = ic::makeSensorDepth(ic::renderDepth(scene, model, 640, 480), 1.425e-3, true, rng);
    if (cl.has("save"))
      cv::imwrite(cl.value("save") + "/rgbd_" + std::to_string(i) + ".png", f.rgb);
    survey.push_back(f);
  }
  return survey;
}

// The room's RGB-D statistics for one detector: stage times, 3D line error by range, the line map's error.
struct RoomRgbdRun
{
  ic::LineMap map;
  Series detect, refine, depth, fit, merge, total, lines_per_frame;
  std::map<int, Series> bucket_distance, bucket_angle;
  std::map<int, int> bucket_total, bucket_matched;
};

const double kBucketEdges[] = {0.0, 1.0, 2.0, 3.0, 4.0, 6.0};
constexpr int kBuckets = 5;

int rangeBucket(double range_m)
{
  int bucket = 0;
  while (bucket + 1 < kBuckets && range_m >= kBucketEdges[bucket + 1])
    ++bucket;
  return bucket;
}

void measureRoomRgbdLines(const std::vector<ic::Line3d>& lines, const Eigen::Vector3d& sensor,
                          const std::vector<ic::Segment3d>& truth, bool verbose, RoomRgbdRun* run)
{
  for (const auto& line : lines)
  {
    const double range = (0.5 * (line.a + line.b) - sensor).norm();
    const int bucket = rangeBucket(range);
    ++run->bucket_total[bucket];
    const ic::Line3dError e = ic::measureLine3d(line.a, line.b, truth, 0.1, 5.0);
    if (e.edge < 0)
      continue;
    ++run->bucket_matched[bucket];
    run->bucket_distance[bucket].add(e.distance_m * 1000.0);
    run->bucket_angle[bucket].add(e.angle_deg);
    if (verbose && (e.distance_m > 0.01 || e.angle_deg > 0.5))
      std::printf(
          "    3D line at %.2f m, edge %d: %.1f mm %.3f deg, %d of %d inliers, rms %.1f mm, image (%.1f %.1f)-"
          "(%.1f %.1f), map (%.3f %.3f %.3f)-(%.3f %.3f %.3f)\n",
          range, e.edge, e.distance_m * 1000.0, e.angle_deg, line.inliers, line.samples, line.rms_m * 1000.0,
          line.image.a.x(), line.image.a.y(), line.image.b.x(), line.image.b.y(), line.a.x(), line.a.y(), line.a.z(),
          line.b.x(), line.b.y(), line.b.z());
  }
}

void printRoomRgbdRun(const RoomRgbdRun& run, ic::SegmentDetectorKind kind, int frames,
                      const std::vector<ic::Segment3d>& truth)
{
  std::printf("\nRGB-D frame 640x480, detector %s (%.1f lines per frame, %zu map lines after %d frames)\n",
              ic::toString(kind), run.lines_per_frame.mean(), run.map.size(), frames);
  printRow("detection", run.detect);
  printRow("2D fine-tuning", run.refine);
  printRow("depth sampling", run.depth);
  printRow("RANSAC + refinement", run.fit);
  printRow("line-map merge", run.merge);
  printRow("total per frame", run.total);
  std::printf("  3D line error against distance from the sensor (lines matched to a true edge within 10 cm, 5 deg):\n");
  for (int b = 0; b < kBuckets; ++b)
  {
    if (!run.bucket_total.count(b) || !run.bucket_total.at(b))
      continue;
    const Series& d = run.bucket_distance.count(b) ? run.bucket_distance.at(b) : Series{};
    const Series& a = run.bucket_angle.count(b) ? run.bucket_angle.at(b) : Series{};
    std::printf("    %.0f-%.0f m: %4d of %4d lines matched, median %6.2f mm  %5.3f deg, p90 %6.2f mm  %5.3f deg\n",
                kBucketEdges[b], kBucketEdges[b + 1], run.bucket_matched.count(b) ? run.bucket_matched.at(b) : 0,
                run.bucket_total.at(b), d.median(), a.median(), d.quantile(0.9), a.quantile(0.9));
  }
  Series map_distance, map_angle;
  int map_matched = 0;
  const auto supported = run.map.lines(3);
  for (const auto& line : supported)
  {
    const ic::Line3dError e = ic::measureLine3d(line.a(), line.b(), truth, 0.1, 5.0);
    if (e.edge < 0)
      continue;
    ++map_matched;
    map_distance.add(e.distance_m * 1000.0);
    map_angle.add(e.angle_deg);
  }
  std::printf(
      "  line map: %zu lines seen >= 3 times, %d on a true edge: median %.2f mm  %.3f deg, p90 %.2f mm  "
      "%.3f deg\n",
      supported.size(), map_matched, map_distance.median(), map_angle.median(), map_distance.quantile(0.9),
      map_angle.quantile(0.9));
}

bool benchRoomRgbd(const std::vector<ic::RgbdFrame>& survey, const std::vector<ic::Segment3d>& truth,
                   ic::SegmentDetectorKind kind, int repeat, bool verbose)
{
  ic::RgbdLineOptions options;
  options.detector.kind = kind;
  ic::RgbdLineExtractor extractor(options);
  RoomRgbdRun run;
  for (const auto& f : survey)
  {
    auto best =
        bestOf<ic::RgbdLineStats>(repeat, [&](ic::RgbdLineStats* stats) { return extractor.extract(f, stats); });
    if (!best)
    {
      std::cerr << "bench_lines: " << best.error().describe() << "\n";
      return false;
    }
    const double t = ic::threadCpuMs();
    run.map.insert(best->value);
    const double merge_ms = ic::cpuMsSince(t);
    run.detect.add(best->stats.detect_ms);
    run.refine.add(best->stats.refine_ms);
    run.depth.add(best->stats.depth_ms);
    run.fit.add(best->stats.fit_ms);
    run.merge.add(merge_ms);
    run.total.add(best->ms + merge_ms);
    run.lines_per_frame.add(best->value.size());
    measureRoomRgbdLines(best->value, f.T_map_camera.translation(), truth, verbose, &run);
  }
  printRoomRgbdRun(run, kind, static_cast<int>(survey.size()), truth);
  return true;
}

struct FixedImage
{
  ic::CameraModel camera;
  cv::Mat image;
};

constexpr int kRoomFixedWidth = 1920, kRoomFixedHeight = 1080;

std::vector<FixedImage> renderRoomFixedImages(const ic::LineScene& scene, int fixed, ic::CommandLine& cl,
                                              std::mt19937& rng)
{
  const int width = kRoomFixedWidth, height = kRoomFixedHeight;
  std::vector<FixedImage> images;
  const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> mounts = {{{0.3, 0.3, 2.5}, {3.6, 3.4, 0.6}},
                                                                           {{5.7, 4.7, 2.5}, {2.2, 1.2, 0.7}},
                                                                           {{5.7, 0.3, 2.4}, {1.5, 3.5, 0.8}},
                                                                           {{0.3, 4.7, 2.5}, {4.0, 1.0, 0.5}}};
  for (int i = 0; i < fixed; ++i)
  {
    const auto& [position, target] = mounts[i % mounts.size()];
    ic::Intrinsics k;
    k.fx = k.fy = 1100.0;
    k.cx = 0.5 * (width - 1) + 7.0;
    k.cy = 0.5 * (height - 1) - 5.0;
    ic::DivisionModel dm;
    dm.center = k.principalPoint();
    dm.lambda = ic::lambdaForCornerDisplacement(dm.center, width, height, -20.0);
    FixedImage fi;
    fi.camera = ic::CameraModel(k, dm, ic::CameraPose::fromWorldFromCamera(lookAt(position, target)));
    ic::LineSceneRenderOptions render;
    render.supersampling = 6;
    render.noise_sigma = 2.0;
    render.blur_sigma_px = 0.6;
    fi.image = ic::renderGrey(scene, fi.camera, width, height, render, rng);
    if (cl.has("save"))
      cv::imwrite(cl.value("save") + "/fixed_" + std::to_string(i) + ".png", fi.image);
    images.push_back(fi);
  }
  return images;
}

void printRoomFixedLine(const ic::ImageLine& line, const ic::ImageLineError& before, const ic::ImageLineError& after)
{
  std::printf(
      "    2D line edge %d: %zu points, %zu fragments, %.0f px, rms before %.3f after %.3f max %.3f px; parts"
      " (contrast/support/residual/samples):",
      after.edge, line.points.size(), line.fragments.size(), line.length_px, before.rms_px, after.rms_px, after.max_px);
  for (const auto& p : line.parts)
    std::printf(" %.0f/%.2f/%.2f/%d", p.contrast, p.support, p.residual_px, p.samples);
  std::printf("\n      from (%.1f %.1f) to (%.1f %.1f)\n", line.points.front().x(), line.points.front().y(),
              line.points.back().x(), line.points.back().y());
}

bool benchRoomFixed(const std::vector<FixedImage>& images, const std::vector<ic::Segment3d>& truth,
                    ic::SegmentDetectorKind kind, int repeat, bool verbose)
{
  const int width = kRoomFixedWidth, height = kRoomFixedHeight;
  ic::ImageLineOptions options;
  options.detector.kind = kind;
  Series detect, merge, refine, total, before, after, lines_per_image;
  int matched = 0, extracted = 0;
  for (const auto& fi : images)
  {
    // The first pass of a calibration: no distortion known, centred on the image.
    ic::DivisionModel first;
    first.center = Eigen::Vector2d(0.5 * (width - 1), 0.5 * (height - 1));
    auto best = bestOf<ic::ImageLineStats>(
        repeat, [&](ic::ImageLineStats* stats) { return ic::extractImageLines(fi.image, first, options, stats); });
    if (!best)
    {
      std::cerr << "bench_lines: " << best.error().describe() << "\n";
      return false;
    }
    detect.add(best->stats.detect_ms);
    merge.add(best->stats.merge_ms);
    refine.add(best->stats.refine_ms);
    total.add(best->ms);
    lines_per_image.add(best->value.size());
    const auto edges = ic::projectEdges(fi.camera, truth);
    for (const auto& line : best->value)
    {
      ++extracted;
      const auto e_after = ic::measureImageLine(line.points, fi.camera.distortion(), edges, 2.0);
      const auto e_before = ic::measureImageLine(line.detected, fi.camera.distortion(), edges, 2.0);
      if (e_after.edge < 0 || e_before.edge < 0)
        continue;
      ++matched;
      after.add(e_after.rms_px);
      before.add(e_before.rms_px);
      if (verbose && e_after.rms_px > 0.1)
        printRoomFixedLine(line, e_before, e_after);
    }
  }
  std::printf("\nfixed-camera image %dx%d, detector %s (%.1f lines per image)\n", width, height, ic::toString(kind),
              lines_per_image.mean());
  printRow("detection", detect);
  printRow("merging", merge);
  printRow("fine-tuning (Eq. 8)", refine);
  printRow("total per image", total);
  std::printf(
      "  2D accuracy: %d of %d lines on a true edge (within 2 px); RMS distance to the true curved edge\n"
      "    before fine-tuning: RMS %.3f px, median %.3f px, p90 %.3f px\n"
      "    after fine-tuning:  RMS %.3f px, median %.3f px, p90 %.3f px\n",
      matched, extracted, before.rms(), before.median(), before.quantile(0.9), after.rms(), after.median(),
      after.quantile(0.9));
  return true;
}

// The synthetic room (synthetic/line_scene.h), the benchmark before the survey simulator existed.
int runRoom(ic::CommandLine& cl, const std::vector<ic::SegmentDetectorKind>& kinds)
{
  const bool verbose = cl.flag("verbose");
  const int frames = static_cast<int>(cl.number("frames", 30));
  const int fixed = static_cast<int>(cl.number("fixed", 2));
  const unsigned seed = static_cast<unsigned>(cl.number("seed", 1));
  const int repeat = std::max(1, static_cast<int>(cl.number("repeat", 3)));
  std::printf("bench_lines --room: seed %u, %d RGB-D frames, %d fixed images, best of %d runs, OpenCV threads %d\n",
              seed, frames, fixed, repeat, cv::getNumThreads());

  std::mt19937 rng(seed);
  const ic::LineScene scene = ic::makeRoomScene(rng);
  const std::vector<ic::Segment3d> truth = scene.edges();

  std::printf("\nrendering %d RGB-D frames (640x480) ...\n", frames);
  const std::vector<ic::RgbdFrame> survey = renderRoomSurvey(scene, frames, cl, rng);
  for (const auto kind : kinds)
    if (!benchRoomRgbd(survey, truth, kind, repeat, verbose))
      return 1;

  std::printf("\nrendering %d fixed-camera images (%dx%d) ...\n", fixed, kRoomFixedWidth, kRoomFixedHeight);
  const std::vector<FixedImage> images = renderRoomFixedImages(scene, fixed, cl, rng);
  for (const auto kind : kinds)
    if (!benchRoomFixed(images, truth, kind, repeat, verbose))
      return 1;
  return 0;
}

// ------------------------------------------------------------------------------------------- the simulator
// Per-line accuracy and timing of the RGB-D half on the simulator's frames, for one detector.
struct RgbdRun
{
  ic::SegmentDetectorKind kind;
  std::unique_ptr<ic::RgbdLineExtractor> extractor;
  ic::LineMap map;
  Series detect, refine, depth, fit, merge, total, lines_per_frame;
  // calibration_node's depth registration estimate (by default) on the frame's segments: a keyframe's cost, not in
  // total (other frames do not pay it).
  ic::DepthRegistrationEstimator registration;
  Series creases;
  std::map<int, Series> bucket_distance, bucket_angle;  // matched lines, by range bucket
  std::map<int, int> bucket_total, bucket_good;         // all lines; within 1 cm and 0.5 deg
  std::vector<double> near_distance, near_angle;        // within 3 m, unmatched lines as infinity
};

struct FixedRun
{
  Series detect, merge, refine, total, lines;
  double before2 = 0.0, after2 = 0.0;  // pooled squared distances of the matched lines
  int samples = 0, matched = 0, extracted = 0;
  Series after_line;  // per-line RMS after fine-tuning
};

void addImageLines(const std::vector<ic::ImageLine>& lines, const ic::CameraModel& truth_camera,
                   const std::vector<ic::TrueEdgeImage>& edges, bool verbose, const std::string& label, FixedRun* run)
{
  for (const auto& line : lines)
  {
    ++run->extracted;
    const auto after = ic::measureImageLine(line.points, truth_camera.distortion(), edges, 2.0);
    const auto before = ic::measureImageLine(line.detected, truth_camera.distortion(), edges, 2.0);
    if (after.edge < 0 || before.edge < 0)
    {
      if (verbose)
        std::printf("    %s: line on no true edge: %zu points, %.0f px, from (%.1f %.1f) to (%.1f %.1f)\n",
                    label.c_str(), line.points.size(), line.length_px, line.points.front().x(), line.points.front().y(),
                    line.points.back().x(), line.points.back().y());
      continue;
    }
    ++run->matched;
    run->after2 += after.rms_px * after.rms_px * after.samples;
    run->before2 += before.rms_px * before.rms_px * after.samples;
    run->samples += after.samples;
    run->after_line.add(after.rms_px);
    if (verbose && after.rms_px > 0.15)
      std::printf(
          "    %s: edge %d, %zu points, %.0f px, rms before %.3f after %.3f max %.3f px, (%.1f %.1f)-(%.1f %.1f)\n",
          label.c_str(), after.edge, line.points.size(), line.length_px, before.rms_px, after.rms_px, after.max_px,
          line.points.front().x(), line.points.front().y(), line.points.back().x(), line.points.back().y());
  }
}

void printTimingTable(const std::vector<std::pair<std::string, const Series*>>& rows)
{
  std::printf("  | stage | mean | median | p90 | max |\n  |---|---|---|---|---|\n");
  for (const auto& [name, s] : rows)
    std::printf("  | %s | %.2f | %.2f | %.2f | %.2f ms |\n", name.c_str(), s->mean(), s->median(), s->quantile(0.9),
                s->max());
}

void printRgbdLine(int frame, const ic::Line3d& line, const ic::Line3dError& e)
{
  std::printf("    frame %d: 3D line at %.2f m", frame, line.range_m);
  if (e.edge < 0)
    std::printf(" on no true edge (within 10 cm, 5 deg):");
  else
    std::printf(", edge %d: %.1f mm %.3f deg, %d of %d inliers, rms %.1f mm:", e.edge, e.distance_m * 1000.0,
                e.angle_deg, line.inliers, line.samples, line.rms_m * 1000.0);
  std::printf(" image (%.1f %.1f)-(%.1f %.1f), map (%.3f %.3f %.3f)-(%.3f %.3f %.3f)\n", line.image.a.x(),
              line.image.a.y(), line.image.b.x(), line.image.b.y(), line.a.x(), line.a.y(), line.a.z(), line.b.x(),
              line.b.y(), line.b.z());
}

void measureRgbdLines(int frame, const std::vector<ic::Line3d>& lines, const std::vector<ic::Segment3d>& truth,
                      bool verbose, RgbdRun* run)
{
  const double inf = std::numeric_limits<double>::infinity();
  for (const auto& line : lines)
  {
    const int bucket = rangeBucket(line.range_m);
    ++run->bucket_total[bucket];
    const ic::Line3dError e = ic::measureLine3d(line.a, line.b, truth, 0.1, 5.0);
    if (line.range_m < 3.0)
    {
      run->near_distance.push_back(e.edge < 0 ? inf : e.distance_m * 1000.0);
      run->near_angle.push_back(e.edge < 0 ? inf : e.angle_deg);
    }
    if (e.edge < 0)
    {
      if (verbose)
        printRgbdLine(frame, line, e);
      continue;
    }
    run->bucket_distance[bucket].add(e.distance_m * 1000.0);
    run->bucket_angle[bucket].add(e.angle_deg);
    run->bucket_good[bucket] += e.distance_m <= 0.01 && e.angle_deg <= 0.5;
    if (verbose && (e.distance_m > 0.01 || e.angle_deg > 0.5))
      printRgbdLine(frame, line, e);
  }
}

bool benchWorldRgbdFrame(int i, const ic::RgbdFrame& frame, const std::vector<ic::Segment3d>& truth, int repeat,
                         bool verbose, RgbdRun* run)
{
  std::vector<ic::Segment2d> segments;
  auto best = bestOf<ic::RgbdLineStats>(
      repeat, [&](ic::RgbdLineStats* stats) { return run->extractor->extract(frame, stats, nullptr, &segments); });
  if (!best)
  {
    std::cerr << "bench_lines: frame " << i << ": " << best.error().describe() << "\n";
    return false;
  }
  double t = ic::threadCpuMs();
  if (run->registration.addFrame(frame, segments, run->extractor->options()))
    run->creases.add(ic::cpuMsSince(t));
  t = ic::threadCpuMs();
  run->map.insert(best->value);
  const double merge_ms = ic::cpuMsSince(t);
  run->detect.add(best->stats.detect_ms);
  run->refine.add(best->stats.refine_ms);
  run->depth.add(best->stats.depth_ms);
  run->fit.add(best->stats.fit_ms);
  run->merge.add(merge_ms);
  run->total.add(best->ms + merge_ms);
  run->lines_per_frame.add(best->value.size());
  measureRgbdLines(i, best->value, truth, verbose, run);
  return true;
}

void printMapAccuracy(const RgbdRun& run, const std::vector<ic::Segment3d>& truth, int support, bool verbose)
{
  Series d, a;
  int on_edge = 0, over5 = 0, over10 = 0;
  const auto lines = run.map.lines(support);
  for (const auto& line : lines)
  {
    const ic::Line3dError e = ic::measureLine3d(line.a(), line.b(), truth, 0.1, 5.0);
    if (e.edge < 0)
    {
      if (verbose)
        std::printf("    map line on no true edge: support %d, %.2f m, (%.3f %.3f %.3f)-(%.3f %.3f %.3f)\n",
                    line.support, line.length(), line.a().x(), line.a().y(), line.a().z(), line.b().x(), line.b().y(),
                    line.b().z());
      continue;
    }
    ++on_edge;
    d.add(e.distance_m * 1000.0);
    a.add(e.angle_deg);
    over5 += e.distance_m > 0.005;
    over10 += e.distance_m > 0.01;
    if (verbose && e.distance_m > 0.005)
      std::printf("    map line %.1f mm %.3f deg off edge %d: support %d, %.2f m, (%.3f %.3f %.3f)-(%.3f %.3f %.3f)\n",
                  e.distance_m * 1000.0, e.angle_deg, e.edge, line.support, line.length(), line.a().x(), line.a().y(),
                  line.a().z(), line.b().x(), line.b().y(), line.b().z());
  }
  std::printf(
      "  line map, support >= %d: %zu lines, %d on a true edge: median %.2f mm %.3f deg, p90 %.2f mm "
      "%.3f deg, max %.2f mm %.3f deg; %d over 5 mm, %d over 1 cm\n",
      support, lines.size(), on_edge, d.median(), a.median(), d.quantile(0.9), a.quantile(0.9), d.max(), a.max(), over5,
      over10);
}

void printWorldRgbdRun(const RgbdRun& run, const sim::World& w, int frames, const std::vector<ic::Segment3d>& truth,
                       int min_support, bool verbose)
{
  std::printf("\nRGB-D frame %dx%d, detector %s: %.1f 3D lines per frame, %zu map lines after %d frames\n",
              w.xtion.width, w.xtion.height, ic::toString(run.kind), run.lines_per_frame.mean(), run.map.size(),
              frames);
  printTimingTable({{"detection", &run.detect},
                    {"2D fine-tuning", &run.refine},
                    {"depth sampling", &run.depth},
                    {"RANSAC + refinement", &run.fit},
                    {"line-map merge", &run.merge},
                    {"**total**", &run.total},
                    {"crease measurement (keyframes only: the node's registration estimate)", &run.creases}});
  std::printf(
      "\n  3D line error against the distance from the sensor (error: RMS of the end points' distances to the "
      "true line; matched: within 10 cm and 5 deg of a true edge):\n");
  std::printf("  | range | lines | matched | within 1 cm, 0.5 deg | median | p90 |\n  |---|---|---|---|---|---|\n");
  for (int b = 0; b < kBuckets; ++b)
  {
    if (!run.bucket_total.count(b) || !run.bucket_total.at(b))
      continue;
    const Series& d = run.bucket_distance.count(b) ? run.bucket_distance.at(b) : Series{};
    const Series& a = run.bucket_angle.count(b) ? run.bucket_angle.at(b) : Series{};
    const int good = run.bucket_good.count(b) ? run.bucket_good.at(b) : 0;
    std::printf("  | %.0f-%.0f m | %d | %d | %d (%.1f %%) | %.2f mm, %.3f deg | %.2f mm, %.3f deg |\n", kBucketEdges[b],
                kBucketEdges[b + 1], run.bucket_total.at(b), static_cast<int>(d.v.size()), good,
                100.0 * good / run.bucket_total.at(b), d.median(), a.median(), d.quantile(0.9), a.quantile(0.9));
  }
  Series nd{run.near_distance}, na{run.near_angle};
  std::printf("  within 3 m: %zu lines, median %.2f mm, %.3f deg (unmatched lines counted as infinite)\n", nd.v.size(),
              nd.median(), na.median());
  for (const int support : {min_support, 3})
    printMapAccuracy(run, truth, support, verbose && support == min_support);
}

// One fixed camera, one pass (lambda 0 at the image centre, or the true distortion), over its noisy frames.
bool benchFixedCameraPass(const sim::SurveySimulator& survey, size_t c, bool true_lambda,
                          const ic::ImageLineOptions& image_options, const std::vector<ic::TrueEdgeImage>& edges,
                          int fixed_frames, int repeat, bool verbose)
{
  const sim::SimulatedFixedCamera& fc = survey.world().fixed_cameras[c];
  ic::DivisionModel distortion;
  distortion.center = Eigen::Vector2d(0.5 * (fc.width - 1), 0.5 * (fc.height - 1));
  if (true_lambda)
    distortion = fc.camera.distortion();
  FixedRun run;
  for (int k = 0; k < fixed_frames; ++k)
  {
    const cv::Mat image = sim::toBgr(survey.fixedFrame(static_cast<int>(c), k).image);
    auto best = bestOf<ic::ImageLineStats>(repeat, [&](ic::ImageLineStats* stats) {
      return ic::extractImageLines(image, distortion, image_options, stats);
    });
    if (!best)
    {
      std::cerr << "bench_lines: " << fc.name << ": " << best.error().describe() << "\n";
      return false;
    }
    run.detect.add(best->stats.detect_ms);
    run.merge.add(best->stats.merge_ms);
    run.refine.add(best->stats.refine_ms);
    run.total.add(best->ms);
    run.lines.add(best->value.size());
    addImageLines(best->value, fc.camera, edges, verbose, fc.name + (true_lambda ? " (true lambda)" : " (lambda 0)"),
                  &run);
  }
  std::printf(
      "  | %s | %dx%d | %s | %.1f | %d of %d | %.1f | %.2f | %.1f | **%.1f** (max %.1f) | %.3f px | %.3f "
      "px | %.3f, %.3f, %.3f px |\n",
      fc.name.c_str(), fc.width, fc.height, true_lambda ? "true lambda" : "lambda 0", run.lines.mean(), run.matched,
      run.extracted, run.detect.mean(), run.merge.mean(), run.refine.mean(), run.total.mean(), run.total.max(),
      std::sqrt(run.before2 / std::max(1, run.samples)), std::sqrt(run.after2 / std::max(1, run.samples)),
      run.after_line.median(), run.after_line.quantile(0.9), run.after_line.max());
  return true;
}

bool benchWorldFixed(ic::CommandLine& cl, const sim::SurveySimulator& survey, const std::vector<ic::Segment3d>& truth,
                     ic::SegmentDetectorKind kind, int fixed_frames, int repeat, bool verbose)
{
  ic::ImageLineOptions image_options;
  image_options.detector.kind = kind;
  image_options.refiner.end_tolerance_px = cl.number("end-tolerance", image_options.refiner.end_tolerance_px);
  image_options.split_kink_px = cl.number("split-kink", image_options.split_kink_px);
  image_options.refiner.min_break_px = cl.number("min-break", image_options.refiner.min_break_px);
  std::printf(
      "\nfixed cameras, detector %s (%d noisy frames each; first pass: lambda = 0 at the image centre; "
      "then with the true lambda and centre)\n",
      ic::toString(kind), fixed_frames);
  std::printf(
      "  | camera | size | pass | lines | on a true edge | detection | merging | fine-tuning | **total** "
      "| RMS before | RMS after | per-line RMS after: median, p90, max |\n"
      "  |---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (size_t c = 0; c < survey.world().fixed_cameras.size(); ++c)
  {
    // Collinear true edges (a row of chairs' seat edges, window panes) are one 3D line for a 2D line.
    const auto edges = ic::projectEdges(survey.world().fixed_cameras[c].camera, ic::mergeCollinearSegments(truth));
    for (const bool true_lambda : {false, true})
      if (!benchFixedCameraPass(survey, c, true_lambda, image_options, edges, fixed_frames, repeat, verbose))
        return false;
  }
  return true;
}

// The survey simulator's frames (simulation/survey.h): every RGB-D frame of a survey and a few noisy frames of
// every fixed camera, against the world's true edges.
int runWorld(ic::CommandLine& cl, const std::vector<ic::SegmentDetectorKind>& kinds)
{
  const bool verbose = cl.flag("verbose");
  const std::string world_path = cl.value("world", std::string(INSITU_SOURCE_DIR) + "/config/worlds/waiting_room.yaml");
  sim::SimulationOptions options;
  options.duration_s = cl.number("duration", 40.0);
  options.rate_hz = cl.number("rate", 5.0);
  options.seed = static_cast<uint64_t>(cl.number("seed", 1));
  const int repeat = std::max(1, static_cast<int>(cl.number("repeat", 3)));
  const int fixed_frames = std::max(0, static_cast<int>(cl.number("fixed-frames", 2)));
  const int max_frames = static_cast<int>(cl.number("frames", 1e9));
  const int min_support = std::max(1, static_cast<int>(cl.number("min-support", 2)));
  auto world = sim::loadWorldFile(world_path);
  if (!world)
  {
    std::cerr << "bench_lines: " << world.error().describe() << "\n";
    return 2;
  }
  if (cl.has("rgb-noise"))
    world->xtion.rgb_noise_sigma = cl.number("rgb-noise", 0.0);
  if (!cl.error().empty())
  {
    std::cerr << "bench_lines: " << cl.error() << "\n" << kUsage;
    return 2;
  }
  auto survey = sim::SurveySimulator::create(std::move(*world), options);
  if (!survey)
  {
    std::cerr << "bench_lines: " << survey.error().describe() << "\n";
    return 2;
  }
  const sim::World& w = survey->world();
  const std::vector<ic::Segment3d> truth = sim::toSegments(sim::computeTrueEdges(w));
  const int frames = static_cast<int>(std::min<size_t>(survey->xtionFrameCount(), std::max(0, max_frames)));
  std::printf(
      "bench_lines --world %s: seed %llu, %d RGB-D frames (%.0f s at %.1f Hz, RGB noise %.1f), %d noisy frames per "
      "fixed camera, %zu true edges, best of %d runs, OpenCV threads %d\n",
      w.name.c_str(), static_cast<unsigned long long>(options.seed), frames, options.duration_s, options.rate_hz,
      w.xtion.rgb_noise_sigma, fixed_frames, truth.size(), repeat, cv::getNumThreads());

  std::vector<RgbdRun> runs;
  for (const auto kind : kinds)
  {
    RgbdRun run;
    run.kind = kind;
    ic::RgbdLineOptions o;
    o.detector.kind = kind;
    run.extractor = std::make_unique<ic::RgbdLineExtractor>(o);
    runs.push_back(std::move(run));
  }
  for (int i = 0; i < frames; ++i)
  {
    const ic::RgbdFrame frame = sim::toRgbdFrame(*survey, survey->xtionFrame(i));
    for (auto& run : runs)
      if (!benchWorldRgbdFrame(i, frame, truth, repeat, verbose, &run))
        return 1;
  }
  for (const auto& run : runs)
    printWorldRgbdRun(run, w, frames, truth, min_support, verbose);
  for (const auto kind : kinds)
    if (!benchWorldFixed(cl, *survey, truth, kind, fixed_frames, repeat, verbose))
      return 1;
  return 0;
}

}  // namespace

int main(int argc, char** argv)
{
  ic::CommandLine cl(argc, argv,
                     {"frames", "fixed", "detector", "seed", "repeat", "save", "world", "duration", "rate",
                      "fixed-frames", "rgb-noise", "min-support", "end-tolerance", "split-kink", "min-break"},
                     {"verbose", "room"});
  if (cl.help())
  {
    std::cout << kUsage;
    return 0;
  }
  const std::string detector_name = cl.value("detector", cl.flag("room") ? "both" : "fld");
  if (!cl.error().empty() || !cl.positional().empty() ||
      (detector_name != "both" && !ic::parseSegmentDetectorKind(detector_name)))
  {
    std::cerr << "bench_lines: " << (cl.error().empty() ? "bad arguments" : cl.error()) << "\n" << kUsage;
    return 2;
  }
  std::vector<ic::SegmentDetectorKind> kinds;
  if (detector_name == "both")
    kinds = {ic::SegmentDetectorKind::kFastLineDetector, ic::SegmentDetectorKind::kLsd};
  else
    kinds = {*ic::parseSegmentDetectorKind(detector_name)};
  cv::setNumThreads(1);
  return cl.flag("room") ? runRoom(cl, kinds) : runWorld(cl, kinds);
}
