// bench_accuracy: the accuracy benchmark against ground truth (the paper's Fig. 2 experiment, outliers, number of
// lines, the OpenCV peer, and the honesty of the reported standard deviations). Writes a CSV and a markdown summary,
// then plots with scripts/plot_accuracy.py.
#include <filesystem>
#include <algorithm>
#include <cstdio>
#include <limits>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <numeric>
#include <optional>
#include <fstream>
#include <iostream>
#include <map>
#include <tuple>
#include <sstream>

#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "command_line.h"
#include "insitu_calibration/refine/refinement.h"
#include "insitu_calibration/calibration.h"
#include "insitu_calibration/lines/gradient_refiner.h"
#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/test_support/line_scene.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

namespace ic = insitu_calibration;

namespace
{
const char* kUsage = R"(Usage: bench_accuracy [--trials N] [--out-dir DIR] [--seed S] [--experiments LIST] [--no-plot]
                      [--previous-defaults] [--linear-stage auto|plumb-line|parts] [--true-noise]

Runs, with N trials per setting (default 100), on synthetic surveillance-like cameras (1280x960, barrel distortion
displacing the corner by 15 px) looking at 30 random 3D segments in a room (5 image points per line, 2 world points):
  fig2      image noise sigma 0..4 px in steps of 0.5: DLT-Points unnormalised and normalised (on the segments' end
            points), DLT-Lines (the paper's linear method), DLT-Lines refined (RANSAC + Ceres, the default path),
            lines and end points combined and refined, and OpenCV's calibrateCamera on the end points (intrinsic
            guess from DLT-Points)
  outliers  0..50 % wrong line correspondences at 1 px: plain DLT-Lines against the robust default path (and an
            oracle that keeps exactly the good lines); outliers_added: wrong lines added to the 30 good ones
  lines     6..200 lines at 1 px: plain DLT-Lines against the default path
  dense     issue 13's hand-clicked data: 40 polylines of 2-12 image points and 2-6 world points (segments 0.5-2 m,
            images >= 80 px), image noise 0.3, 1 and 3 px with world noise 0.9, 3 and 9 mm: calibrate_lines'
            defaults against OpenCV's calibrateCamera on the end points with the same noise; prints the medians
  dense_fixed  the issue's own cases at 1 px: 6 image and 6 world points per line (3 mm), 10 image points and exact
            world points
--previous-defaults runs every experiment with the pipeline as it was before issue 13 (DLT over parts, fixed RANSAC
threshold, image-point line residuals), for before/after comparisons in one binary; --linear-stage forces one linear
stage (calibrate_lines --linear-stage) everywhere. --true-noise gives the dense experiments' refinement the true noise
levels (--image-sigma, --world-sigma) instead of its estimates, to measure what estimating them costs; the medians
printed include the noise levels the refinement used.
(--experiments picks some of fig2,fig2_rendered,outliers,outliers_added,lines,dense,dense_fixed; all by default) and reports the coverage of the
refined result's standard deviations (how often the true error is within 2 sigma).
Writes DIR/accuracy.csv, DIR/accuracy.md and PNG plots (DIR defaults to ./accuracy). Errors are against the truth:
relative focal error |fx - fx_true| / fx_true, reprojection error = RMS distance between the estimated and the true
projection of the segments' end points (px).
)";

struct Trial
{
  ic::CameraModel truth;
  ic::SyntheticLines lines;
  std::vector<ic::PointCorrespondence> points;  // noisy end points
};

Trial makeTrial(unsigned seed, double noise_px, int lines)
{
  std::mt19937 rng(seed);
  Trial t;
  ic::SyntheticCameraOptions camera_options;
  t.truth = ic::randomCamera(camera_options, rng);
  ic::SyntheticLineOptions options;
  options.lines = lines;
  options.image_points_per_line = 5;
  options.world_points_per_line = 2;
  options.image_noise_px = noise_px;
  t.lines = ic::makeSyntheticLines(t.truth, camera_options.image_width, camera_options.image_height, options, rng);
  t.points = ic::endPointCorrespondences(t.truth, t.lines.segments, noise_px, rng);
  return t;
}

struct Errors
{
  bool ok = false;
  double focal = 0.0;
  double reprojection_px = 0.0;
  double rotation_deg = 0.0;
  double center_m = 0.0;
  double lambda = 0.0;
  double inlier_fraction = 1.0;  // lines kept by the robust path
  // The joint error model's noise levels (given or estimated); NaN without it.
  double image_sigma_px = std::numeric_limits<double>::quiet_NaN();
  double world_sigma_mm = std::numeric_limits<double>::quiet_NaN();
  // Refined results only: whether the truth is within 2 sigma, per parameter (-1: no sigma).
  int fx_covered = -1;
  int cx_covered = -1;
  int lambda_covered = -1;
  int position_covered = -1;
  int rotation_covered = -1;
};

double reprojectionAgainstTruth(const ic::CameraModel& truth, const std::vector<ic::Segment3d>& segments,
                                const std::function<std::optional<Eigen::Vector2d>(const Eigen::Vector3d&)>& project)
{
  double sum = 0.0;
  size_t n = 0;
  for (const auto& s : segments)
    for (const Eigen::Vector3d& x : {s.a, s.b})
    {
      const auto m_true = truth.project(x);
      const auto m = project(x);
      if (!m_true)
        continue;
      const double d = m ? (*m - *m_true).norm() : 1e3;
      sum += d * d;
      ++n;
    }
  return n ? std::sqrt(sum / n) : 0.0;
}

Errors errorsOf(const Trial& t, const ic::CameraModel& estimate)
{
  Errors e;
  e.ok = true;
  const ic::CameraErrors c = ic::compareCameras(t.truth, estimate);
  e.focal = std::abs(c.focal_relative);
  e.rotation_deg = c.rotation_rad * 180.0 / M_PI;
  e.center_m = c.center_m;
  e.lambda = c.lambda_relative;
  e.reprojection_px = reprojectionAgainstTruth(t.truth, t.lines.segments,
                                               [&](const Eigen::Vector3d& x) { return estimate.project(x); });
  return e;
}

// The pipeline as it was before issue 13: the DLT over parts without fallback, the fixed RANSAC threshold, image-point
// residuals to the line through the first and last world points (bit for bit the previous results).
ic::CalibrationOptions previousDefaults()
{
  ic::CalibrationOptions options;
  options.linear_stage = ic::LinearStage::kParts;
  options.lambda_fallback = false;
  options.noise_threshold_factor = 0.0;
  options.refinement.line_residual = ic::LineResidual::kImagePoints;
  return options;
}

// --previous-defaults: every experiment with previousDefaults() instead of CalibrationOptions' defaults.
bool g_previous_defaults = false;
std::optional<ic::LinearStage> g_linear_stage;  // --linear-stage: measure the stages against each other
ic::CalibrationOptions baseOptions()
{
  ic::CalibrationOptions options = g_previous_defaults ? previousDefaults() : ic::CalibrationOptions();
  if (g_linear_stage)
    options.linear_stage = *g_linear_stage;
  return options;
}

Errors runCalibration(const Trial& t, const ic::CorrespondenceSet& data, ic::DltMethod method, bool normalize,
                      bool robust, double inlier_threshold_px, ic::CalibrationOptions options = baseOptions())
{
  options.method = method;
  options.distortion = ic::DistortionMode::kOn;
  options.dlt.normalize = normalize;
  options.ransac = robust;
  options.refine = robust;
  options.ransac_options.inlier_threshold_px = inlier_threshold_px;
  const auto result = ic::calibrateCamera(data, options);
  if (!result)
    return {};
  Errors e = errorsOf(t, result->camera);
  e.inlier_fraction = static_cast<double>(result->inlier_count) / std::max<size_t>(1, data.lines.size());
  if (result->refinement && result->refinement->image_sigma_px > 0.0)
  {
    e.image_sigma_px = result->refinement->image_sigma_px;
    e.world_sigma_mm = 1000.0 * result->refinement->world_sigma_m;
  }
  const ic::CameraUncertainty& u = result->uncertainty;
  if (robust && u.available)
  {
    const ic::Intrinsics& k = result->camera.intrinsics();
    e.fx_covered = std::abs(k.fx - t.truth.intrinsics().fx) < 2.0 * u.fx;
    e.cx_covered = std::abs(k.cx - t.truth.intrinsics().cx) < 2.0 * u.cx;
    e.lambda_covered = std::abs(result->camera.distortion().lambda - t.truth.distortion().lambda) < 2.0 * u.lambda;
    e.position_covered = e.center_m < 2.0 * u.position_m;
    e.rotation_covered = e.rotation_deg < 2.0 * u.rotation_deg;
  }
  return e;
}

// OpenCV's calibrateCamera on the end points: a 3D rig needs an intrinsic guess, taken from normalised DLT-Points.
Errors runOpenCv(const Trial& t, int width, int height)
{
  if (t.points.size() < 6)
    return {};
  ic::CorrespondenceSet data;
  data.image_width = width;
  data.image_height = height;
  data.points = t.points;
  ic::DltOptions dlt;
  dlt.method = ic::DltMethod::kPoints;
  const auto guess = ic::solveDlt(data, dlt);
  if (!guess)
    return {};
  std::vector<std::vector<cv::Point3f>> object(1);
  std::vector<std::vector<cv::Point2f>> image(1);
  for (const auto& p : t.points)
  {
    object[0].emplace_back(p.world.x(), p.world.y(), p.world.z());
    image[0].emplace_back(p.image.x(), p.image.y());
  }
  cv::Mat k;
  const ic::Intrinsics& g = guess->camera.intrinsics();
  cv::eigen2cv(Eigen::Matrix3d(ic::Intrinsics{g.fx, g.fy, 0.0, g.cx, g.cy}.matrix()), k);
  cv::Mat distortion = cv::Mat::zeros(5, 1, CV_64F);
  std::vector<cv::Mat> rvecs, tvecs;
  try
  {
    cv::calibrateCamera(object, image, cv::Size(width, height), k, distortion, rvecs, tvecs,
                        cv::CALIB_USE_INTRINSIC_GUESS | cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K3);
  }
  catch (const cv::Exception&)
  {
    return {};
  }
  cv::Mat r;
  cv::Rodrigues(rvecs[0], r);
  ic::CameraModel estimate;
  Eigen::Matrix3d k_eigen, r_eigen;
  cv::cv2eigen(k, k_eigen);
  cv::cv2eigen(r, r_eigen);
  estimate.intrinsics() = ic::Intrinsics::fromMatrix(k_eigen);
  estimate.pose().rotation = r_eigen;
  estimate.pose().translation = Eigen::Vector3d(tvecs[0].at<double>(0), tvecs[0].at<double>(1), tvecs[0].at<double>(2));
  Errors e = errorsOf(t, estimate);
  e.lambda = std::numeric_limits<double>::quiet_NaN();  // a different distortion model
  e.reprojection_px = reprojectionAgainstTruth(t.truth, t.lines.segments, [&](const Eigen::Vector3d& x) {
    std::vector<cv::Point2f> out;
    cv::projectPoints(std::vector<cv::Point3f>{cv::Point3f(x.x(), x.y(), x.z())}, rvecs[0], tvecs[0], k, distortion,
                      out);
    return std::optional<Eigen::Vector2d>(Eigen::Vector2d(out[0].x, out[0].y));
  });
  return e;
}

ic::CorrespondenceSet linesOf(const Trial& t)
{
  return t.lines.data;
}

ic::CorrespondenceSet pointsOf(const Trial& t)
{
  ic::CorrespondenceSet d;
  d.image_width = t.lines.data.image_width;
  d.image_height = t.lines.data.image_height;
  d.points = t.points;
  return d;
}

// Swaps the world side of a fraction of the lines with other lines' (wrong correspondences); `clean` receives the
// lines left untouched (what an oracle would keep).
ic::CorrespondenceSet withOutliers(const Trial& t, double fraction, std::mt19937& rng, ic::CorrespondenceSet* clean)
{
  ic::CorrespondenceSet d = t.lines.data;
  const size_t n = d.lines.size();
  const size_t wrong = static_cast<size_t>(std::round(fraction * n));
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  for (size_t k = 0; k < wrong; ++k)
  {
    // A cyclic shift within the wrong set never gives a line its own world side back.
    const size_t i = order[k];
    const size_t j = wrong > 1 ? order[(k + 1) % wrong] : order[(k + 1) % n];
    d.lines[i].world = t.lines.data.lines[j].world;
  }
  *clean = t.lines.data;
  clean->lines.clear();
  for (size_t k = wrong; k < n; ++k)
    clean->lines.push_back(t.lines.data.lines[order[k]]);
  return d;
}

// The paper's Fig. 2 with images: a rendered room (flat-shaded quads, anti-aliased, 2 grey levels of pixel noise)
// seen by a distorted camera; the image lines start sigma px off their true position and are fine-tuned on the
// image gradient (Eq. 8) before the DLT.
struct RenderedTrial
{
  ic::CameraModel truth;
  std::vector<ic::Segment3d> edges;  // visible parts
  std::vector<std::vector<Eigen::Vector2d>> true_lines;
  std::optional<ic::LineRefiner> refiner;
};

RenderedTrial makeRenderedTrial(unsigned seed, int width, int height)
{
  std::mt19937 rng(seed);
  RenderedTrial t;
  const ic::LineScene scene = ic::makeRoomScene(rng);
  ic::SyntheticCameraOptions camera_options;
  camera_options.height_m = 2.4;
  t.truth = ic::randomCamera(camera_options, rng);
  ic::LineSceneRenderOptions render;
  render.noise_sigma = 2.0;
  const cv::Mat image = ic::renderGrey(scene, t.truth, width, height, render, rng);
  for (const auto& edge : scene.edges())
  {
    const auto interval = ic::visibleInterval(t.truth, edge, width, height);
    if (!interval)
      continue;
    const ic::Segment3d visible{edge.pointAt(interval->first), edge.pointAt(interval->second)};
    std::vector<Eigen::Vector2d> line;
    for (int k = 0; k < 5; ++k)
      line.push_back(*t.truth.project(visible.pointAt(k / 4.0)));
    if ((line.back() - line.front()).norm() < 60.0)
      continue;
    t.edges.push_back(visible);
    t.true_lines.push_back(line);
  }
  ic::RefinerOptions options;
  auto refiner = ic::LineRefiner::create(image, options);
  if (refiner)
    t.refiner.emplace(std::move(*refiner));
  return t;
}

// calibrate_lines' defaults where they differ from CalibrationOptions' (the refinement's joint error model); with
// --true-noise the data's true noise levels are given (as --image-sigma and --world-sigma would).
bool g_true_noise = false;
ic::CalibrationOptions calibrateLinesDefaults(double image_sigma_px, double world_sigma_m)
{
  ic::CalibrationOptions options = baseOptions();
  if (!g_previous_defaults)
  {
    options.refinement.line_residual = ic::LineResidual::kJoint;
    options.detect_left_handed = true;
    if (g_true_noise)
    {
      options.refinement.image_sigma_px = image_sigma_px;
      options.refinement.world_sigma_m = world_sigma_m;
    }
  }
  return options;
}

// Issue 13's data: 40 dense polylines (2-12 image points, 2-6 world points, 0.5-2 m), image noise sigma px and
// world noise 3 mm x sigma; OpenCV gets the segments' end points with the same image and world noise.
// image_points / world_points > 0 fix the counts (the issue's own trials: 6 and 6 at 1 px / 3 mm, 10 and exact).
Trial makeDenseTrial(unsigned seed, double noise_px, int image_points = 0, int world_points = 0,
                     double world_noise_per_px_m = 0.003)
{
  std::mt19937 rng(seed);
  Trial t;
  t.truth = ic::randomCamera(ic::SyntheticCameraOptions(), rng);
  ic::DensePolylineOptions options;
  options.image_noise_px = noise_px;
  options.world_noise_m = world_noise_per_px_m * noise_px;
  if (image_points > 0)
    options.image_points_min = options.image_points_max = image_points;
  if (world_points > 0)
    options.world_points_min = options.world_points_max = world_points;
  t.lines = ic::makeDensePolylines(t.truth, 1280, 960, options, rng);
  std::normal_distribution<double> standard(0.0, 1.0);
  for (const auto& s : t.lines.segments)
    for (const Eigen::Vector3d& x : {s.a, s.b})
      if (const auto m = t.truth.project(x))
        t.points.push_back({*m + noise_px * Eigen::Vector2d(standard(rng), standard(rng)),
                            x + options.world_noise_m * Eigen::Vector3d(standard(rng), standard(rng), standard(rng))});
  return t;
}

double median(std::vector<double> v)
{
  if (v.empty())
    return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// One line per (x, method) of an experiment: failures and the medians the issue's goals are stated in.
void printMedians(const std::string& experiment,
                  const std::map<std::tuple<std::string, double, std::string>, std::vector<Errors>>& groups)
{
  std::printf("%-14s %6s %-28s %8s %10s %10s %9s %9s %9s %9s %10s %10s\n", "experiment", "x", "method", "failures",
              "focal %", "rot deg", "pos mm", "lambda %", "reproj px", "inliers %", "sigma px", "sigma mm");
  for (const auto& [key, errors] : groups)
  {
    if (std::get<0>(key) != experiment)
      continue;
    std::vector<double> focal, rotation, center, lambda, reprojection, kept, image_sigma, world_sigma;
    int failures = 0;
    for (const Errors& e : errors)
    {
      if (!e.ok)
      {
        ++failures;
        continue;
      }
      focal.push_back(100.0 * e.focal);
      rotation.push_back(e.rotation_deg);
      center.push_back(1000.0 * e.center_m);
      lambda.push_back(100.0 * std::abs(e.lambda));
      reprojection.push_back(e.reprojection_px);
      kept.push_back(100.0 * e.inlier_fraction);
      if (std::isfinite(e.image_sigma_px))
      {
        image_sigma.push_back(e.image_sigma_px);
        world_sigma.push_back(e.world_sigma_mm);
      }
    }
    std::printf("%-14s %6g %-28s %4d/%-3zu %10.4f %10.4f %9.2f %9.2f %9.3f %9.1f %10.3f %10.2f\n", experiment.c_str(),
                std::get<1>(key), std::get<2>(key).c_str(), failures, errors.size(), median(focal), median(rotation),
                median(center), median(lambda), median(reprojection), median(kept), median(image_sigma),
                median(world_sigma));
  }
}

struct Writer
{
  std::ofstream csv;
  std::map<std::tuple<std::string, double, std::string>, std::vector<Errors>> groups;  // (experiment, x, method)

  void add(const std::string& experiment, double x, const std::string& method, int trial, const Errors& e)
  {
    csv << experiment << "," << x << "," << method << "," << trial << "," << (e.ok ? 1 : 0) << "," << e.focal << ","
        << e.reprojection_px << "," << e.rotation_deg << "," << e.center_m << "," << e.lambda << "," << e.fx_covered
        << "," << e.cx_covered << "," << e.lambda_covered << "," << e.position_covered << "," << e.rotation_covered
        << "\n";
    groups[{experiment, x, method}].push_back(e);
  }
};

// What every experiment needs: where its rows go, how many trials from which seed, the image size.
struct BenchRun
{
  Writer& w;
  int trials;
  unsigned seed;
  int width = 1280;
  int height = 960;
};

// Fig. 2 of the paper: image noise 0..4 px, the DLT variants, refinement and OpenCV.
void runFig2(const BenchRun& r)
{
  Writer& w = r.w;
  const int trials = r.trials, width = r.width, height = r.height;
  const unsigned seed = r.seed;
  for (int step = 0; step <= 8; ++step)
  {
    const double noise = 0.5 * step;
    const double threshold = std::max(3.0, 4.0 * noise);
    for (int k = 0; k < trials; ++k)
    {
      const Trial t = makeTrial(seed + 1000 * step + k, noise, 30);
      w.add("fig2", noise, "dlt_points_unnormalised", k,
            runCalibration(t, pointsOf(t), ic::DltMethod::kPoints, false, false, threshold));
      w.add("fig2", noise, "dlt_points", k,
            runCalibration(t, pointsOf(t), ic::DltMethod::kPoints, true, false, threshold));
      w.add("fig2", noise, "dlt_lines", k,
            runCalibration(t, linesOf(t), ic::DltMethod::kLines, true, false, threshold));
      w.add("fig2", noise, "dlt_lines_refined", k,
            runCalibration(t, linesOf(t), ic::DltMethod::kLines, true, true, threshold));
      ic::CorrespondenceSet combined = linesOf(t);
      combined.points = t.points;
      w.add("fig2", noise, "combined_refined", k,
            runCalibration(t, combined, ic::DltMethod::kCombined, true, true, threshold));
      w.add("fig2", noise, "opencv_calibrate_camera", k, runOpenCv(t, width, height));
    }
    std::cout << "fig2: sigma " << noise << " px done" << std::endl;
  }
}

// One rendered trial at one noise level: the true lines with noise, and the same fine-tuned on the image.
void addRenderedTrial(const BenchRun& r, const RenderedTrial& rendered, double noise, int k)
{
  Writer& w = r.w;
  const int width = r.width, height = r.height;
  const unsigned seed = r.seed;
  const int step = static_cast<int>(std::lround(noise / 0.5));
  const double threshold = std::max(3.0, 4.0 * noise);
  std::mt19937 rng(seed + 40000 + 1000 * step + k);
  std::normal_distribution<double> n(0.0, 1.0);
  ic::CorrespondenceSet noisy, tuned;
  noisy.image_width = tuned.image_width = width;
  noisy.image_height = tuned.image_height = height;
  // The fine-tuning searches as far as the initial error can reach.
  ic::RefinerOptions options = rendered.refiner->options();
  options.search_px = std::max(2.0, 3.0 * noise);
  auto refiner = ic::LineRefiner::create(rendered.refiner->image(), options);
  for (size_t i = 0; i < rendered.edges.size(); ++i)
  {
    ic::LineCorrespondence line;
    line.world = {rendered.edges[i].a, rendered.edges[i].b};
    for (const auto& m : rendered.true_lines[i])
      line.image.push_back(m + noise * Eigen::Vector2d(n(rng), n(rng)));
    const auto fine = refiner ? refiner->refinePolyline(line.image)
                              : ic::Expected<ic::RefinedPolyline>(ic::Error(ic::ErrorCode::kNoSolution, ""));
    if (!fine || fine->failed_parts > 0)
      continue;  // an edge hidden in the image: no line there to fine-tune
    noisy.lines.push_back(line);
    line.image = fine->points;
    tuned.lines.push_back(line);
  }
  Trial t;
  t.truth = rendered.truth;
  t.lines.segments = rendered.edges;
  w.add("fig2_rendered", noise, "dlt_lines", k,
        runCalibration(t, noisy, ic::DltMethod::kLines, true, false, threshold));
  w.add("fig2_rendered", noise, "dlt_lines_finetuned", k,
        runCalibration(t, tuned, ic::DltMethod::kLines, true, false, threshold));
  w.add("fig2_rendered", noise, "dlt_lines_finetuned_refined", k,
        runCalibration(t, tuned, ic::DltMethod::kLines, true, true, threshold));
}

// The rendered Fig. 2: fine-tuned lines. One image per trial, every noise level on it.
void runFig2Rendered(const BenchRun& r)
{
  std::vector<RenderedTrial> rendered;
  for (int k = 0; k < r.trials; ++k)
    rendered.push_back(makeRenderedTrial(r.seed + 30000 + k, r.width, r.height));
  for (int step = 0; step <= 8; ++step)
  {
    const double noise = 0.5 * step;
    for (int k = 0; k < r.trials; ++k)
      if (rendered[k].refiner)
        addRenderedTrial(r, rendered[k], noise, k);
    std::cout << "fig2_rendered: sigma " << noise << " px done" << std::endl;
  }
}

// 0..50 % wrong line correspondences at 1 px.
void runOutliers(const BenchRun& r)
{
  Writer& w = r.w;
  const int trials = r.trials;
  const unsigned seed = r.seed;
  for (int step = 0; step <= 5; ++step)
  {
    const double fraction = 0.1 * step;
    std::mt19937 rng(seed + 77 * step);
    for (int k = 0; k < trials; ++k)
    {
      const Trial t = makeTrial(seed + 50000 + 1000 * step + k, 1.0, 30);
      ic::CorrespondenceSet clean;
      const ic::CorrespondenceSet data = withOutliers(t, fraction, rng, &clean);
      w.add("outliers", fraction, "oracle_inliers_refined", k,
            runCalibration(t, clean, ic::DltMethod::kLines, true, true, 3.0));
      w.add("outliers", fraction, "dlt_lines", k, runCalibration(t, data, ic::DltMethod::kLines, true, false, 3.0));
      w.add("outliers", fraction, "dlt_lines_refined", k,
            runCalibration(t, data, ic::DltMethod::kLines, true, true, 3.0));
    }
    std::cout << "outliers: " << 100 * fraction << " % done" << std::endl;
  }
}

// The same with the wrong correspondences added to the 30 good lines (a fraction of the total), so that the data
// an oracle would keep do not shrink: the robust path's own cost.
void runOutliersAdded(const BenchRun& r)
{
  Writer& w = r.w;
  const int trials = r.trials;
  const unsigned seed = r.seed;
  for (int step = 0; step <= 5; ++step)
  {
    const double fraction = 0.1 * step;
    std::mt19937 rng(seed + 177 * step);
    for (int k = 0; k < trials; ++k)
    {
      const Trial t = makeTrial(seed + 70000 + 1000 * step + k, 1.0, 30);
      const Trial extra = makeTrial(seed + 80000 + 1000 * step + k, 1.0, 30);
      ic::CorrespondenceSet data = t.lines.data;
      const size_t good = data.lines.size();
      const size_t wrong = static_cast<size_t>(std::round(fraction * good / (1.0 - fraction)));
      // Another scene's image lines paired with this scene's world lines: wrong, but plausible lines.
      for (size_t i = 0; i < wrong && i < extra.lines.data.lines.size(); ++i)
      {
        ic::LineCorrespondence line = extra.lines.data.lines[i];
        line.world = t.lines.data.lines[std::uniform_int_distribution<size_t>(0, good - 1)(rng)].world;
        data.lines.push_back(line);
      }
      w.add("outliers_added", fraction, "dlt_lines", k,
            runCalibration(t, data, ic::DltMethod::kLines, true, false, 3.0));
      w.add("outliers_added", fraction, "dlt_lines_refined", k,
            runCalibration(t, data, ic::DltMethod::kLines, true, true, 3.0));
    }
    std::cout << "outliers_added: " << 100 * fraction << " % done" << std::endl;
  }
}

// 7..200 lines at 1 px.
void runLines(const BenchRun& r)
{
  Writer& w = r.w;
  const int trials = r.trials;
  const unsigned seed = r.seed;
  for (int lines : {7, 8, 10, 15, 20, 30, 50, 100, 200})
  {
    for (int k = 0; k < trials; ++k)
    {
      const Trial t = makeTrial(seed + 90000 + 1000 * lines + k, 1.0, lines);
      w.add("lines", lines, "dlt_lines", k, runCalibration(t, linesOf(t), ic::DltMethod::kLines, true, false, 3.0));
      w.add("lines", lines, "dlt_lines_refined", k,
            runCalibration(t, linesOf(t), ic::DltMethod::kLines, true, true, 3.0));
    }
    std::cout << "lines: " << lines << " done" << std::endl;
  }
}

// Issue 13: dense noisy polylines and noisy 3D points, the calibrate_lines defaults against OpenCV on points.
void runDense(const BenchRun& r)
{
  Writer& w = r.w;
  const int trials = r.trials, width = r.width, height = r.height;
  const unsigned seed = r.seed;
  for (double noise : {0.3, 1.0, 3.0})
  {
    for (int k = 0; k < trials; ++k)
    {
      const Trial t = makeDenseTrial(seed + 110000 + static_cast<unsigned>(1000 * noise) + k, noise);
      w.add("dense", noise, "calibrate_lines_default", k,
            runCalibration(t, linesOf(t), ic::DltMethod::kLines, true, true, 3.0,
                           calibrateLinesDefaults(noise, 0.003 * noise)));
      w.add("dense", noise, "previous_defaults", k,
            runCalibration(t, linesOf(t), ic::DltMethod::kLines, true, true, 3.0, previousDefaults()));
      w.add("dense", noise, "opencv_calibrate_camera", k, runOpenCv(t, width, height));
    }
    std::cout << "dense: sigma " << noise << " px done" << std::endl;
  }
}

// The issue's own two cases at 1 px: 6 image and 6 world points per line with 3 mm world noise (x = 6), and 10
// image points with exact world points (x = 10).
void runDenseFixed(const BenchRun& r)
{
  Writer& w = r.w;
  const int trials = r.trials, width = r.width, height = r.height;
  const unsigned seed = r.seed;
  for (int case_points : {6, 10})
  {
    for (int k = 0; k < trials; ++k)
    {
      const Trial t = case_points == 6 ? makeDenseTrial(seed + 130000 + k, 1.0, 6, 6)
                                       : makeDenseTrial(seed + 140000 + k, 1.0, 10, 2, 0.0);
      w.add("dense_fixed", case_points, "calibrate_lines_default", k,
            runCalibration(t, linesOf(t), ic::DltMethod::kLines, true, true, 3.0,
                           calibrateLinesDefaults(1.0, case_points == 6 ? 0.003 : 0.0)));
      w.add("dense_fixed", case_points, "previous_defaults", k,
            runCalibration(t, linesOf(t), ic::DltMethod::kLines, true, true, 3.0, previousDefaults()));
      w.add("dense_fixed", case_points, "opencv_calibrate_camera", k, runOpenCv(t, width, height));
    }
    std::cout << "dense_fixed: " << case_points << " image points done" << std::endl;
  }
}

// One row of the markdown summary: means over the successful trials, failures counted, and the sigmas' coverage.
std::string summaryRow(const std::string& experiment, double x, const std::string& method,
                       const std::vector<Errors>& errors)
{
  double focal = 0, reprojection = 0, rotation = 0, center = 0, lambda = 0;
  int ok = 0;
  int covered[5] = {0, 0, 0, 0, 0};
  int with_sigma = 0;
  for (const Errors& e : errors)
  {
    if (!e.ok)
      continue;
    ++ok;
    focal += e.focal;
    reprojection += e.reprojection_px;
    rotation += e.rotation_deg;
    center += e.center_m;
    lambda += e.lambda;
    if (e.fx_covered >= 0)
    {
      ++with_sigma;
      covered[0] += e.fx_covered;
      covered[1] += e.cx_covered;
      covered[2] += e.lambda_covered;
      covered[3] += e.position_covered;
      covered[4] += e.rotation_covered;
    }
  }
  char row[512];
  const double n = std::max(ok, 1);
  std::string coverage = "";
  if (with_sigma > 0)
  {
    char c[128];
    std::snprintf(c, sizeof(c), "%.0f / %.0f / %.0f / %.0f / %.0f %%", 100.0 * covered[0] / with_sigma,
                  100.0 * covered[1] / with_sigma, 100.0 * covered[2] / with_sigma, 100.0 * covered[3] / with_sigma,
                  100.0 * covered[4] / with_sigma);
    coverage = c;
  }
  std::snprintf(row, sizeof(row), "| %s | %g | %s | %d / %zu | %.4f | %.4f | %.4f | %.3f | %.3f | %s |\n",
                experiment.c_str(), x, method.c_str(), ok, errors.size(), 100.0 * focal / n, reprojection / n,
                rotation / n, 1000.0 * center / n, 100.0 * lambda / n, coverage.c_str());
  return row;
}

// DIR/accuracy.md: one summary row per experiment, x and method.
void writeMarkdown(const std::string& out_dir, const Writer& w)
{
  std::ofstream md(out_dir + "/accuracy.md");
  md << "| experiment | x | method | ok / trials | mean focal error % | mean reprojection px | mean rotation deg | "
        "mean centre mm | mean lambda error % | 2-sigma coverage fx / cx / lambda / position / rotation |\n"
     << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& [key, errors] : w.groups)
  {
    const auto& [experiment, x, method] = key;
    md << summaryRow(experiment, x, method, errors);
  }
}

// Reads the run-wide flags into the globals the experiments read; false (after saying why) on a bad value.
bool readGlobalFlags(const ic::CommandLine& cli)
{
  g_previous_defaults = cli.flag("previous-defaults");
  g_true_noise = cli.flag("true-noise");
  if (!cli.has("linear-stage"))
    return true;
  g_linear_stage = ic::parseLinearStage(cli.value("linear-stage"));
  if (g_linear_stage)
    return true;
  std::cerr << "bench_accuracy: --linear-stage must be auto, plumb-line or parts\n";
  return false;
}
}  // namespace

int main(int argc, char** argv)
{
  ic::quietSolverLogging();
  ic::CommandLine cli(argc, argv, {"trials", "out-dir", "seed", "experiments", "linear-stage"},
                      {"no-plot", "previous-defaults", "true-noise"});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  if (!readGlobalFlags(cli))
    return 2;
  const int trials = static_cast<int>(cli.number("trials", 100));
  const unsigned seed = static_cast<unsigned>(cli.number("seed", 1000));
  const std::string out_dir = cli.value("out-dir", "accuracy");
  if (!cli.error().empty() || trials <= 0)
  {
    std::cerr << "bench_accuracy: " << (cli.error().empty() ? "--trials must be positive" : cli.error()) << "\n\n"
              << kUsage;
    return 2;
  }
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  Writer w;
  w.csv.open(out_dir + "/accuracy.csv");
  if (!w.csv)
  {
    std::cerr << "bench_accuracy: cannot write " << out_dir << "/accuracy.csv\n";
    return 1;
  }
  w.csv << "experiment,x,method,trial,ok,focal_rel,reprojection_px,rotation_deg,center_m,lambda_rel,fx_covered,"
           "cx_covered,lambda_covered,position_covered,rotation_covered\n";
  std::cout << "bench_accuracy: " << trials << " trials per setting, seed " << seed << "\n";
  const std::string experiments =
      "," + cli.value("experiments", "fig2,fig2_rendered,outliers,outliers_added,lines,dense,dense_fixed") + ",";
  const auto runs = [&](const char* name) {
    return experiments.find("," + std::string(name) + ",") != std::string::npos;
  };
  const BenchRun run{w, trials, seed};
  const std::vector<std::pair<const char*, void (*)(const BenchRun&)>> all = {{"fig2", runFig2},
                                                                              {"fig2_rendered", runFig2Rendered},
                                                                              {"outliers", runOutliers},
                                                                              {"outliers_added", runOutliersAdded},
                                                                              {"lines", runLines},
                                                                              {"dense", runDense},
                                                                              {"dense_fixed", runDenseFixed}};
  for (const auto& [name, experiment] : all)
    if (runs(name))
      experiment(run);
  if (runs("dense"))
    printMedians("dense", w.groups);
  if (runs("dense_fixed"))
    printMedians("dense_fixed", w.groups);
  w.csv.close();
  writeMarkdown(out_dir, w);
  std::cout << "wrote " << out_dir << "/accuracy.csv and " << out_dir << "/accuracy.md\n";
  if (cli.flag("no-plot"))
    return 0;
  const std::string script = std::string(INSITU_SOURCE_DIR) + "/scripts/plot_accuracy.py";
  if (std::system(("/usr/bin/python3 '" + script + "' '" + out_dir + "'").c_str()) != 0)
  {
    std::cerr << "bench_accuracy: plotting failed (" << script << ")\n";
    return 1;
  }
  return 0;
}
