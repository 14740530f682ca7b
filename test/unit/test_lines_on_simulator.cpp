// Line extraction against the survey simulator's ground truth (issue 4's accuracy checks): the default survey of
// the default world (config/worlds/waiting_room.yaml, 40 s, 200 RGB-D frames, seed 1) simulated in memory, with the
// true cameras, poses and 3D edges the simulation core provides.
//   (a) fixed cameras, sensor noise on: fine-tuned 2D lines against the true edges projected with the true K, lambda
//       and pose: RMS distance under 0.15 px (before and after fine-tuning reported), for the first pass (lambda = 0
//       at the image centre) and with the true distortion;
//   (b) 3D lines of the Xtion frames: median error against the true edges under 1 cm and 0.5 deg within 3 m of the
//       sensor (lines on no true edge count as infinitely wrong); the error against the distance is printed;
//   (c) the line map of the survey: every line the calibration uses lies on a true edge.
// The numbers printed here are the ones docs/lines.md quotes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "insitu_calibration/lines/image_lines.h"
#include "insitu_calibration/lines/line_evaluation.h"
#include "insitu_calibration/lines/line_map.h"
#include "insitu_calibration/lines/rgbd_lines.h"
#include "insitu_calibration/simulation/line_frames.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/true_edges.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
constexpr uint64_t kSeed = 1;
const std::string kWorld = std::string(INSITU_SOURCE_DIR) + "/config/worlds/waiting_room.yaml";

double quantile(std::vector<double> v, double q)
{
  if (v.empty())
    return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(std::floor(q * (v.size() - 1) + 0.5)))];
}

double median(const std::vector<double>& v)
{
  return quantile(v, 0.5);
}

// One simulated survey and its truth, shared by the tests of this file.
class LinesOnSimulator : public ::testing::Test
{
protected:
  static void SetUpTestSuite()
  {
    auto world = sim::loadWorldFile(kWorld);
    ASSERT_TRUE(world) << world.error().describe();
    sim::SimulationOptions options;  // the default survey: 40 s, 5 Hz, depth and image noise on
    options.seed = kSeed;
    auto survey = sim::SurveySimulator::create(std::move(*world), options);
    ASSERT_TRUE(survey) << survey.error().describe();
    survey_ = std::make_unique<sim::SurveySimulator>(std::move(*survey));
    truth_ = sim::toSegments(sim::computeTrueEdges(survey_->world()));
    std::printf("world %s, seed %llu, %zu RGB-D frames, %zu fixed cameras, %zu true edges\n",
                survey_->world().name.c_str(), static_cast<unsigned long long>(kSeed), survey_->xtionFrameCount(),
                survey_->world().fixed_cameras.size(), truth_.size());
  }
  static void TearDownTestSuite() { survey_.reset(); }

  static std::unique_ptr<sim::SurveySimulator> survey_;
  static std::vector<ic::Segment3d> truth_;
};

std::unique_ptr<sim::SurveySimulator> LinesOnSimulator::survey_;
std::vector<ic::Segment3d> LinesOnSimulator::truth_;

}  // namespace

namespace
{
// Every fixed camera of a survey, frame 0, lambda = 0 at the image centre and the true distortion: RMS after
// fine-tuning < 0.15 px, >= 95 % of the lines on a true edge. Returns whether a camera is 1920x1080.
bool checkFixedCameras(const sim::SurveySimulator& survey, const std::vector<ic::Segment3d>& truth)
{
  const sim::World& world = survey.world();
  EXPECT_FALSE(world.fixed_cameras.empty());
  bool has_full_hd = false;
  for (size_t c = 0; c < world.fixed_cameras.size(); ++c)
  {
    const sim::SimulatedFixedCamera& fc = world.fixed_cameras[c];
    has_full_hd |= fc.width == 1920 && fc.height == 1080;
    // Collinear true edges (a row of chairs' seat edges, window panes) are one 3D line for a 2D line.
    const auto edges = ic::projectEdges(fc.camera, ic::mergeCollinearSegments(truth));
    const cv::Mat image = sim::toBgr(survey.fixedFrame(static_cast<int>(c), 0).image);
    for (const bool true_distortion : {false, true})
    {
      ic::DivisionModel distortion;
      distortion.center = Eigen::Vector2d(0.5 * (fc.width - 1), 0.5 * (fc.height - 1));
      if (true_distortion)
        distortion = fc.camera.distortion();
      ic::ImageLineStats stats;
      const auto lines = ic::extractImageLines(image, distortion, ic::ImageLineOptions(), &stats);
      EXPECT_TRUE(lines) << lines.error().describe();
      if (!lines)
        continue;
      double before2 = 0.0, after2 = 0.0;
      int samples = 0, on_edge = 0;
      std::vector<double> per_line;
      for (const auto& line : *lines)
      {
        const auto after = ic::measureImageLine(line.points, fc.camera.distortion(), edges);
        const auto before = ic::measureImageLine(line.detected, fc.camera.distortion(), edges);
        if (after.edge < 0 || before.edge < 0)
          continue;
        ++on_edge;
        after2 += after.rms_px * after.rms_px * after.samples;
        before2 += before.rms_px * before.rms_px * after.samples;
        samples += after.samples;
        per_line.push_back(after.rms_px);
      }
      const double rms_before = std::sqrt(before2 / std::max(1, samples));
      const double rms_after = std::sqrt(after2 / std::max(1, samples));
      const double on_edge_fraction = static_cast<double>(on_edge) / std::max<size_t>(1, lines->size());
      std::printf(
          "%-9s %4dx%-4d %-11s: %3zu lines, %3d on a true edge (%.1f %%); RMS distance before fine-tuning "
          "%.3f px, after %.3f px (per line: median %.3f, p90 %.3f, max %.3f px)\n",
          fc.name.c_str(), fc.width, fc.height, true_distortion ? "true lambda" : "lambda 0", lines->size(), on_edge,
          100.0 * on_edge_fraction, rms_before, rms_after, median(per_line), quantile(per_line, 0.9),
          quantile(per_line, 1.0));
      EXPECT_GE(on_edge, 30) << fc.name;
      EXPECT_LT(rms_after, 0.15) << fc.name << (true_distortion ? ", true lambda" : ", lambda 0");
      EXPECT_GE(on_edge_fraction, 0.95) << fc.name << (true_distortion ? ", true lambda" : ", lambda 0");
    }
  }
  return has_full_hd;
}
}  // namespace

// (a) Every fixed camera, one noisy frame, first pass (lambda = 0 at the image centre) and with the true distortion.
// The RMS is over every sample (1 px apart) of every line that lies on a true edge (within 2 px over 90 % of its
// length); lines on no true edge are counted and bounded separately.
TEST_F(LinesOnSimulator, FixedCameraLinesFineTunedOntoTrueEdges)
{
  ASSERT_TRUE(survey_);
  EXPECT_TRUE(checkFixedCameras(*survey_, truth_)) << "the default world should have a 1920x1080 camera";
}

// The same on the larger world (config/worlds/corridor.yaml, six cameras): its junctions of nearly collinear edges
// and of edges meeting at a few degrees are where polylines straddle two edges (split, re-fitted, trimmed).
TEST(LinesOnCorridorWorld, FixedCameraLinesFineTunedOntoTrueEdges)
{
  auto world = sim::loadWorldFile(std::string(INSITU_SOURCE_DIR) + "/config/worlds/corridor.yaml");
  ASSERT_TRUE(world) << world.error().describe();
  sim::SimulationOptions options;
  options.seed = kSeed;
  options.duration_s = 1.0;  // only the fixed cameras' first frames are used
  auto survey = sim::SurveySimulator::create(std::move(*world), options);
  ASSERT_TRUE(survey) << survey.error().describe();
  const auto truth = sim::toSegments(sim::computeTrueEdges(survey->world()));
  std::printf("world %s, %zu fixed cameras, %zu true edges\n", survey->world().name.c_str(),
              survey->world().fixed_cameras.size(), truth.size());
  EXPECT_EQ(survey->world().fixed_cameras.size(), 6u);
  checkFixedCameras(*survey, truth);
}

// (b) and (c): every RGB-D frame of the survey through the extractor into one line map (as the survey does with its
// keyframes; here every frame).
TEST_F(LinesOnSimulator, RgbdLinesAndLineMapOnTrueEdges)
{
  ASSERT_TRUE(survey_);
  ic::RgbdLineExtractor extractor;
  ic::LineMap map;
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> bucket_edges = {0.0, 1.0, 2.0, 3.0, 4.0, 6.0};
  std::vector<std::vector<double>> distance_mm(bucket_edges.size() - 1), angle_deg(bucket_edges.size() - 1);
  std::vector<double> near_distance_mm, near_angle_deg;
  size_t frames_with_lines = 0;
  for (size_t i = 0; i < survey_->xtionFrameCount(); ++i)
  {
    const ic::RgbdFrame frame = sim::toRgbdFrame(*survey_, survey_->xtionFrame(static_cast<int>(i)));
    ic::RgbdLineStats stats;
    const auto lines = extractor.extract(frame, &stats);
    ASSERT_TRUE(lines) << "frame " << i << ": " << lines.error().describe();
    frames_with_lines += !lines->empty();
    map.insert(*lines);
    for (const auto& line : *lines)
    {
      const ic::Line3dError e = ic::measureLine3d(line.a, line.b, truth_, 0.1, 5.0);
      const double d = e.edge < 0 ? inf : 1000.0 * e.distance_m;
      const double a = e.edge < 0 ? inf : e.angle_deg;
      size_t b = 0;
      while (b + 2 < bucket_edges.size() && line.range_m >= bucket_edges[b + 1])
        ++b;
      distance_mm[b].push_back(d);
      angle_deg[b].push_back(a);
      if (line.range_m < 3.0)
      {
        near_distance_mm.push_back(d);
        near_angle_deg.push_back(a);
      }
    }
  }
  EXPECT_GE(frames_with_lines, survey_->xtionFrameCount() * 9 / 10);
  std::printf("3D lines against the distance from the sensor (unmatched: on no true edge within 10 cm and 5 deg):\n");
  for (size_t b = 0; b + 1 < bucket_edges.size(); ++b)
  {
    const size_t unmatched = std::count(distance_mm[b].begin(), distance_mm[b].end(), inf);
    std::printf("  %.0f-%.0f m: %5zu lines, %3zu unmatched, median %6.2f mm %6.3f deg, p90 %6.2f mm %6.3f deg\n",
                bucket_edges[b], bucket_edges[b + 1], distance_mm[b].size(), unmatched, median(distance_mm[b]),
                median(angle_deg[b]), quantile(distance_mm[b], 0.9), quantile(angle_deg[b], 0.9));
  }
  std::printf("  within 3 m: %zu lines, median %.2f mm, %.3f deg\n", near_distance_mm.size(), median(near_distance_mm),
              median(near_angle_deg));
  ASSERT_GE(near_distance_mm.size(), 200u);
  EXPECT_LT(median(near_distance_mm), 10.0);
  EXPECT_LT(median(near_angle_deg), 0.5);

  // (c) The map lines the calibration uses (the survey's default min_map_support = 2) lie on true edges: both end
  // points within 1 cm of a true edge's line, overlapping it.
  const int min_support = 2;
  const auto lines = map.lines(min_support);
  std::vector<double> map_distance_mm, map_angle_deg;
  int off = 0;
  for (const auto& line : lines)
  {
    const ic::Line3dError e = ic::measureLine3d(line.a(), line.b(), truth_, 0.1, 5.0);
    const double d = e.edge < 0 ? inf : 1000.0 * e.distance_m;
    map_distance_mm.push_back(d);
    map_angle_deg.push_back(e.edge < 0 ? inf : e.angle_deg);
    if (d > 10.0)
    {
      ++off;
      if (off <= 10)
        std::printf("  map line off its edge: %.1f mm, support %d, %.2f m, (%.3f %.3f %.3f)-(%.3f %.3f %.3f)\n", d,
                    line.support, line.length(), line.a().x(), line.a().y(), line.a().z(), line.b().x(), line.b().y(),
                    line.b().z());
    }
  }
  std::printf(
      "line map: %zu lines, %zu seen >= %d times: median %.2f mm %.3f deg, p90 %.2f mm %.3f deg, max %.2f mm; "
      "%d more than 1 cm off a true edge\n",
      map.size(), lines.size(), min_support, median(map_distance_mm), median(map_angle_deg),
      quantile(map_distance_mm, 0.9), quantile(map_angle_deg, 0.9), quantile(map_distance_mm, 1.0), off);
  ASSERT_GE(lines.size(), 50u);
  EXPECT_EQ(off, 0);
}
