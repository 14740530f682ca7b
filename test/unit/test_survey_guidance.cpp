// What a refused camera tells the operator (survey_guidance.h), against the simulator's truth: each fixed camera of
// the default world rendered, its image lines extracted, and the map a survey would give (the true edges it sees)
// projected through the true camera. With the whole map little or nothing is unmapped; with the map lines of the
// left half of the view dropped (a survey that covered only the right half), the left cells are marked, the sentence
// names the left part, and the floor polygon it sends the robot to holds the feet of the dropped edges' surfaces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/io/calibration_store.h"
#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/survey/fixed_camera.h"
#include "insitu_calibration/survey/survey_guidance.h"
#include "insitu_calibration/survey/survey_hint_file.h"
#include "insitu_calibration/test_support/edges_in_view.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const std::string kWorld = std::string(INSITU_SOURCE_DIR) + "/config/worlds/waiting_room.yaml";

struct SeenEdge
{
  ic::Segment3d segment;
  Eigen::Vector2d image_middle;  // the projection of its middle (distorted px)
  Eigen::Vector3d middle;        // in the map
};

// The map a survey would give: the true edges whose middle the camera sees (not hidden behind a surface).
std::vector<SeenEdge> seenEdges(const sim::World& world, const ic::CameraModel& camera, const sim::RenderedView& view)
{
  std::vector<SeenEdge> out;
  for (const ic::Segment3d& e : ic::edgesSeenInView(world, camera, view))
  {
    const Eigen::Vector3d m = 0.5 * (e.a + e.b);
    out.push_back({e, *camera.project(m), m});
  }
  return out;
}

// The true edges no part of which the camera sees (in front of it and inside its image).
std::vector<ic::Segment3d> outOfView(const sim::World& world, const ic::CameraModel& camera, int width, int height)
{
  std::vector<ic::Segment3d> out;
  for (const auto& e : sim::computeTrueEdges(world))
    if (!ic::visibleInterval(camera, {e.start, e.end}, width, height))
      out.push_back({e.start, e.end});
  return out;
}

std::vector<ic::Segment3d> segmentsOf(const std::vector<SeenEdge>& edges)
{
  std::vector<ic::Segment3d> out;
  for (const auto& e : edges)
    out.push_back(e.segment);
  return out;
}

// Distance from a point to a convex polygon (0 inside).
double distanceToPolygon(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& polygon)
{
  std::vector<cv::Point2f> contour;
  for (const auto& v : polygon)
    contour.emplace_back(static_cast<float>(v.x()), static_cast<float>(v.y()));
  const double signed_distance =
      cv::pointPolygonTest(contour, cv::Point2f(static_cast<float>(p.x()), static_cast<float>(p.y())), true);
  return std::max(0.0, -signed_distance);
}

// Of the outer left and right quarters of the view (columns 0-1 and 6-7), the cells that hold lines and how many of
// those are unmapped.
struct QuarterCells
{
  size_t left_lines = 0, left_unmapped = 0, right_lines = 0, right_unmapped = 0;
};
QuarterCells countQuarterCells(const ic::SurveyGuidance& g)
{
  QuarterCells q;
  for (size_t c = 0; c < g.cells.size(); ++c)
  {
    const int column = static_cast<int>(c) % g.columns;
    const bool unmapped = g.cells[c] == ic::GuidanceCell::kUnmapped;
    if (g.cells[c] == ic::GuidanceCell::kEmpty)
      continue;
    if (column < 2)
      ++q.left_lines, q.left_unmapped += unmapped ? 1 : 0;
    if (column >= g.columns - 2)
      ++q.right_lines, q.right_unmapped += unmapped ? 1 : 0;
  }
  return q;
}

// Each edge's foot (its middle on the floor) to the nearest region's floor polygon, sorted.
std::vector<double> distancesToRegions(const std::vector<SeenEdge>& edges, const ic::SurveyGuidance& g)
{
  std::vector<double> distances;
  for (const auto& e : edges)
  {
    double d = 1e9;
    for (const auto& region : g.regions)
      d = std::min(d, distanceToPolygon(e.middle.head<2>(), region.floor_polygon));
    distances.push_back(d);
  }
  std::sort(distances.begin(), distances.end());
  return distances;
}

// The cells as rows of C (covered), U (unmapped) and E (empty).
void printCells(const ic::SurveyGuidance& g)
{
  for (int row = 0; row < g.rows; ++row)
  {
    std::string line = "  ";
    for (int col = 0; col < g.columns; ++col)
      line += "CUE"[static_cast<int>(g.cells[row * g.columns + col])];
    std::printf("%s\n", line.c_str());
  }
}

struct RenderedCamera
{
  const sim::SimulatedFixedCamera* camera = nullptr;
  cv::Mat grey;
  std::vector<std::vector<Eigen::Vector2d>> lines;
  std::vector<SeenEdge> edges;
};

RenderedCamera renderCamera(const sim::World& world, const sim::Renderer& renderer,
                            const sim::SimulatedFixedCamera& cam)
{
  RenderedCamera r;
  r.camera = &cam;
  const auto view = renderer.render(sim::ViewCamera::fromModel(cam.camera, cam.width, cam.height));
  cv::cvtColor(view.rgb, r.grey, cv::COLOR_RGB2GRAY);
  const auto lines = ic::extractImageLines(r.grey, cam.camera);
  if (lines)
    for (const auto& l : *lines)
      r.lines.push_back(l.points);
  r.edges = seenEdges(world, cam.camera, view);
  return r;
}

class SurveyGuidanceTest : public ::testing::Test
{
protected:
  static void SetUpTestSuite()
  {
    auto world = sim::loadWorldFile(kWorld);
    ASSERT_TRUE(world) << world.error().describe();
    world_ = new sim::World(std::move(*world));
    const sim::Renderer renderer(*world_);
    cameras_ = new std::vector<RenderedCamera>();
    for (const auto& cam : world_->fixed_cameras)
      cameras_->push_back(renderCamera(*world_, renderer, cam));
  }
  static void TearDownTestSuite()
  {
    delete cameras_;
    delete world_;
  }
  static sim::World* world_;
  static std::vector<RenderedCamera>* cameras_;
};
sim::World* SurveyGuidanceTest::world_ = nullptr;
std::vector<RenderedCamera>* SurveyGuidanceTest::cameras_ = nullptr;
}  // namespace

TEST_F(SurveyGuidanceTest, FullySurveyedCameraGetsLittleGuidance)
{
  const ic::SurveyGuidanceOptions options;
  for (const RenderedCamera& r : *cameras_)
  {
    ASSERT_GT(r.lines.size(), 20u) << r.camera->name;
    const auto g = ic::computeSurveyGuidance(r.camera->camera, r.camera->width, r.camera->height, r.lines,
                                             segmentsOf(r.edges), options.tolerance_px, options);
    size_t unexplained_lines = 0;
    for (const auto& region : g.regions)
      unexplained_lines += region.image_lines;
    std::printf("%s full map: %zu unmapped, %zu covered, %zu empty cells; %zu regions, %zu lines: %s\n",
                r.camera->name.c_str(), g.count(ic::GuidanceCell::kUnmapped), g.count(ic::GuidanceCell::kCovered),
                g.count(ic::GuidanceCell::kEmpty), g.regions.size(), unexplained_lines, g.sentence().c_str());
    EXPECT_LE(g.count(ic::GuidanceCell::kUnmapped), 3u) << r.camera->name;  // of 48
    EXPECT_LE(unexplained_lines * 10, r.lines.size()) << r.camera->name;
  }
}

TEST_F(SurveyGuidanceTest, HalfSurveyedViewMarksTheMissingHalfAndWhereItsSurfacesStand)
{
  const ic::SurveyGuidanceOptions options;
  for (const RenderedCamera& r : *cameras_)
  {
    const int width = r.camera->width, height = r.camera->height;
    // The survey mapped the building except the left half of this camera's view: every edge out of its view, and
    // of the edges it sees those in the right half.
    std::vector<ic::Segment3d> kept = outOfView(*world_, r.camera->camera, width, height);
    std::vector<SeenEdge> dropped, seen_kept;
    for (const auto& e : r.edges)
      if (e.image_middle.x() < 0.5 * width)
        dropped.push_back(e);
      else
        kept.push_back(e.segment), seen_kept.push_back(e);
    const auto g =
        ic::computeSurveyGuidance(r.camera->camera, width, height, r.lines, kept, options.tolerance_px, options);
    std::printf("%s right half mapped (%zu of %zu edges): %s\n", r.camera->name.c_str(), kept.size(), r.edges.size(),
                g.sentence().c_str());
    const QuarterCells q = countQuarterCells(g);
    std::printf("  left quarter: %zu of %zu cells unmapped; right quarter: %zu of %zu\n", q.left_unmapped, q.left_lines,
                q.right_unmapped, q.right_lines);
    EXPECT_GE(q.left_unmapped * 10, q.left_lines * 8) << r.camera->name;
    EXPECT_LE(q.right_unmapped * 10, q.right_lines * 1) << r.camera->name;
    ASSERT_FALSE(g.regions.empty()) << r.camera->name;
    const ic::UnmappedRegion& main = g.regions.front();
    EXPECT_NE(main.where.find("left"), std::string::npos) << r.camera->name << ": " << main.where;
    EXPECT_NE(g.sentence().find("survey the " + main.where + " part of the view"), std::string::npos);

    // The feet of the dropped edges' surfaces (their middles on the floor) lie in or near the regions' polygons.
    const std::vector<double> distances = distancesToRegions(dropped, g);
    const double median = distances[distances.size() / 2];
    const double p80 = distances[distances.size() * 8 / 10];
    std::printf(
        "  %zu dropped edges' feet to the floor polygons: median %.2f m, 80th percentile %.2f m; robot at "
        "(%.2f, %.2f) looking (%.2f, %.2f)\n",
        dropped.size(), median, p80, main.robot_position.x(), main.robot_position.y(), main.look_direction.x(),
        main.look_direction.y());
    EXPECT_LT(median, 0.5) << r.camera->name;
    EXPECT_LT(p80, 1.0) << r.camera->name;
    const size_t dropped_near = std::count_if(distances.begin(), distances.end(), [](double d) { return d < 0.5; });
    EXPECT_GE(dropped_near * 10, dropped.size() * 6) << r.camera->name;
    // ... and the polygons are not the whole view's floor: most feet of the right half's surfaces lie outside.
    auto inside = [&](const SeenEdge& e) {
      for (const auto& region : g.regions)
        if (distanceToPolygon(e.middle.head<2>(), region.floor_polygon) == 0.0)
          return true;
      return false;
    };
    const size_t kept_inside = std::count_if(seen_kept.begin(), seen_kept.end(), inside);
    const size_t dropped_inside = std::count_if(dropped.begin(), dropped.end(), inside);
    printCells(g);
    std::printf(
        "  in the regions' polygons: %zu of %zu dropped edges' feet (%zu within 0.5 m), %zu of %zu kept ones'\n",
        dropped_inside, dropped.size(), dropped_near, kept_inside, seen_kept.size());
    EXPECT_LE(kept_inside * 10, seen_kept.size() * 3) << r.camera->name;
    // The robot stands in the room, and the main region's polygon lies ahead of it.
    EXPECT_TRUE(main.robot_position.x() > 0.0 && main.robot_position.x() < 8.0 && main.robot_position.y() > 0.0 &&
                main.robot_position.y() < 6.0)
        << r.camera->name;
    Eigen::Vector2d polygon_mean = Eigen::Vector2d::Zero();
    for (const auto& v : main.floor_polygon)
      polygon_mean += v / static_cast<double>(main.floor_polygon.size());
    EXPECT_GT((polygon_mean - main.robot_position).dot(main.look_direction), 0.5) << r.camera->name;

    const cv::Mat hint = ic::drawSurveyHint(r.grey, g);
    EXPECT_EQ(hint.cols, width);
    EXPECT_EQ(hint.rows, height);
    EXPECT_EQ(hint.type(), CV_8UC3);
  }
}

TEST_F(SurveyGuidanceTest, FixedCameraFromItsPriorAndTheRefusalMessage)
{
  const RenderedCamera& r = cameras_->front();
  ic::FixedCameraConfig config;
  config.name = r.camera->name;
  config.image_topic = "/" + r.camera->name + "/image_raw";
  config.image_width = r.camera->width;
  config.image_height = r.camera->height;
  ic::CameraPrior prior;
  prior.position = r.camera->camera.pose().center();
  prior.direction = r.camera->camera.pose().rotation.row(2).transpose();
  prior.horizontal_fov_deg = 2.0 * std::atan(0.5 * r.camera->width / r.camera->camera.intrinsics().fx) * 180.0 / M_PI;
  config.prior = prior;
  ic::FixedCamera camera(config, {});
  // A refused result guides only with a plausible focal length (one of 0.0035 px showed a region "254061 m high").
  EXPECT_TRUE(camera.focalIsPlausible(r.camera->camera));
  ic::CameraModel absurd = r.camera->camera;
  absurd.intrinsics().fx = absurd.intrinsics().fy = 0.0035;
  EXPECT_FALSE(camera.focalIsPlausible(absurd));
  absurd.intrinsics().fx = absurd.intrinsics().fy = std::nan("");
  EXPECT_FALSE(camera.focalIsPlausible(absurd));
  // Nor far from its prior (one line matched put a hall's camera 1.5 km up: a region "1475 m high").
  EXPECT_TRUE(camera.isPlausible(r.camera->camera));
  EXPECT_FALSE(camera.isPlausible(absurd));
  ic::CameraModel aloft = r.camera->camera;
  aloft.pose().translation -= aloft.pose().rotation * Eigen::Vector3d(0.0, 0.0, 1470.0);  // centre 1470 m higher
  EXPECT_TRUE(camera.focalIsPlausible(aloft));
  EXPECT_FALSE(camera.isPlausible(aloft));
  EXPECT_FALSE(ic::guideSurvey(camera, segmentsOf(r.edges), {}));  // no image yet
  ASSERT_TRUE(camera.addImage(r.grey));
  const auto full = ic::guideSurvey(camera, segmentsOf(r.edges), {});
  ASSERT_TRUE(full) << full.error().describe();
  EXPECT_LE(full->count(ic::GuidanceCell::kUnmapped), 3u);
  const auto empty_map = ic::guideSurvey(camera, {}, {});
  ASSERT_TRUE(empty_map) << empty_map.error().describe();
  ASSERT_FALSE(empty_map->regions.empty());
  EXPECT_GE(empty_map->count(ic::GuidanceCell::kUnmapped), 24u);  // half of the view at least
  const std::string message =
      ic::describeRefusal(ic::Error(ic::ErrorCode::kNotEnoughData, "only 3 lines matched"), *empty_map);
  std::printf("%s\n", message.c_str());
  EXPECT_NE(message.find("only 3 lines matched. What to do: survey the "), std::string::npos);
  EXPECT_NE(message.find("drive the robot to about ("), std::string::npos);
  EXPECT_EQ(ic::describeRefusal(ic::Error(ic::ErrorCode::kNotEnoughData, "x"), ic::SurveyGuidance{}),
            ic::Error(ic::ErrorCode::kNotEnoughData, "x").describe());
}

// A view too weakly determined whose image lines all have map lines: the advice is not "survey more of the view"
// (the robot has been there) but edges at other depths; with unmapped parts the regions to survey come first.
TEST_F(SurveyGuidanceTest, AWeakViewAlreadyMappedIsToldWhatHelpsInstead)
{
  const RenderedCamera& r = cameras_->front();
  const ic::Error weak(ic::ErrorCode::kDegenerate, "the matched lines determine the camera too weakly");
  const ic::SurveyGuidanceOptions options;
  // Every edge the camera sees in the map (a few unexplained pieces of lines may leave a small region).
  const auto mapped = ic::computeSurveyGuidance(r.camera->camera, r.camera->width, r.camera->height, r.lines,
                                                segmentsOf(r.edges), options.tolerance_px, options);
  const size_t covered = mapped.count(ic::GuidanceCell::kCovered);
  ASSERT_GT(covered, 0u);
  ASSERT_LE(8 * mapped.count(ic::GuidanceCell::kUnmapped), covered + mapped.count(ic::GuidanceCell::kUnmapped));
  const std::string advice = ic::describeRefusal(weak, mapped);
  std::printf("%s\n", advice.c_str());
  EXPECT_EQ(advice.find(weak.describe() + ". What to do: "), 0u);
  EXPECT_NE(advice.find("the view is mapped already where it has image lines (" + std::to_string(covered) + " of "),
            std::string::npos);
  EXPECT_NE(advice.find("Survey edges at other depths"), std::string::npos);
  // Not for the other refusals (a wrong match, not enough data), nor for a view the map barely covers.
  EXPECT_EQ(ic::describeRefusal(ic::Error(ic::ErrorCode::kNoSolution, "x"), mapped).find("mapped already"),
            std::string::npos);
  const auto unmapped = ic::computeSurveyGuidance(r.camera->camera, r.camera->width, r.camera->height, r.lines, {},
                                                  options.tolerance_px, options);
  ASSERT_FALSE(unmapped.regions.empty());
  const std::string survey_more = ic::describeRefusal(weak, unmapped);
  EXPECT_NE(survey_more.find(". What to do: survey the "), std::string::npos);
  EXPECT_EQ(survey_more.find("mapped already"), std::string::npos);
}

// The hint beside the overlay: written atomically (what a killed write left is removed at start-up), and removed by
// the calibration that supersedes the refusal.
TEST_F(SurveyGuidanceTest, TheStoreKeepsTheHintBesideTheOverlayUntilACalibration)
{
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("test_survey_guidance_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const ic::CalibrationStore store(dir.string());
  const RenderedCamera& r = cameras_->front();
  const auto g = ic::computeSurveyGuidance(r.camera->camera, r.camera->width, r.camera->height, r.lines, {}, 12.0);
  EXPECT_FALSE(store.saveSurveyHint("cam", cv::Mat()));
  ASSERT_TRUE(store.saveSurveyHint("cam", ic::drawSurveyHint(r.grey, g)));
  EXPECT_EQ(store.surveyHintPath("cam"), (dir / "cam_survey_hint.png").string());
  EXPECT_GT(fs::file_size(store.surveyHintPath("cam")), 1000u);
  std::ofstream(dir / "cam_survey_hint.png.tmp.Ab3xYz") << "killed";
  EXPECT_EQ(store.removeStaleTemporaries({"cam"}).size(), 1u);
  ic::CalibrationFile file;
  file.camera_name = "cam";
  file.image_width = r.camera->width;
  file.image_height = r.camera->height;
  file.camera = r.camera->camera;
  const ic::Status saved = store.save("cam", file, cv::Mat());
  ASSERT_TRUE(saved) << saved.error().describe();
  EXPECT_FALSE(fs::exists(store.surveyHintPath("cam")));
  fs::remove_all(dir);
}

namespace
{
// The share of the edges whose middle the Xtion has in view (horizontal field widened by the operator's sweep) and
// within `reach_m` from the region's standpoint, looking along its look direction.
double shareInXtionView(const std::vector<SeenEdge>& edges, const ic::UnmappedRegion& region,
                        const ic::XtionView& xtion, double sweep_deg, double reach_m)
{
  size_t seen = 0;
  for (const SeenEdge& e : edges)
  {
    const Eigen::Vector2d v = e.middle.head<2>() - region.robot_position;
    const double rise = e.middle.z() - xtion.height_m;
    const double bearing = std::acos(std::clamp(v.normalized().dot(region.look_direction), -1.0, 1.0)) * 180.0 / M_PI;
    const double elevation = std::atan2(rise, v.norm()) * 180.0 / M_PI - xtion.pitch_deg;
    if (std::hypot(v.norm(), rise) <= reach_m && bearing <= xtion.horizontal_half_fov_deg + sweep_deg &&
        std::abs(elevation) <= xtion.vertical_half_fov_deg)
      ++seen;
  }
  return edges.empty() ? 0.0 : static_cast<double>(seen) / edges.size();
}

// The share of the edges one of the guidance's standpoints has in the Xtion's view.
double shareInAnyStandpointsView(const std::vector<SeenEdge>& edges, const ic::SurveyGuidance& g,
                                 const ic::XtionView& xtion, double sweep_deg, double reach_m)
{
  size_t seen = 0;
  for (const SeenEdge& e : edges)
    seen += std::any_of(g.regions.begin(), g.regions.end(),
                        [&](const ic::UnmappedRegion& region) {
                          return shareInXtionView({e}, region, xtion, sweep_deg, reach_m) > 0.0;
                        })
                ? 1
                : 0;
  return edges.empty() ? 0.0 : static_cast<double>(seen) / edges.size();
}

struct HalfSurvey
{
  std::vector<ic::Segment3d> kept;
  std::vector<SeenEdge> dropped;
};

// The survey mapped the building except the left half of this camera's view.
HalfSurvey leftHalfUnmapped(const sim::World& world, const RenderedCamera& r)
{
  HalfSurvey h;
  h.kept = outOfView(world, r.camera->camera, r.camera->width, r.camera->height);
  for (const auto& e : r.edges)
    if (e.image_middle.x() < 0.5 * r.camera->width)
      h.dropped.push_back(e);
    else
      h.kept.push_back(e.segment);
  return h;
}
}  // namespace

// With the Xtion's view known, the standpoint is chosen so that the Xtion sees what the region shows: from it, at
// least as many of the dropped edges are in the Xtion's view as from the fixed 2 m standoff on every camera, and
// more over the three (the region is half the view: no one standpoint has all of it in view).
TEST_F(SurveyGuidanceTest, TheStandpointBringsTheMissingStructureIntoTheXtionsView)
{
  const ic::XtionView level{1.0, 0.0, 22.5, 29.0};
  double sum_before = 0.0, sum_after = 0.0;
  for (const RenderedCamera& r : *cameras_)
  {
    const HalfSurvey h = leftHalfUnmapped(*world_, r);
    ic::SurveyGuidanceOptions plain, aware;
    aware.xtions.push_back(level);
    const auto before = ic::computeSurveyGuidance(r.camera->camera, r.camera->width, r.camera->height, r.lines, h.kept,
                                                  plain.tolerance_px, plain);
    const auto after = ic::computeSurveyGuidance(r.camera->camera, r.camera->width, r.camera->height, r.lines, h.kept,
                                                 aware.tolerance_px, aware);
    ASSERT_FALSE(before.regions.empty() || after.regions.empty()) << r.camera->name;
    const double share_before = shareInXtionView(h.dropped, before.regions.front(), level, aware.look_sweep_deg, 4.0);
    const double share_after = shareInAnyStandpointsView(h.dropped, after, level, aware.look_sweep_deg, 4.0);
    const auto& region = after.regions.front();
    std::printf(
        "%s: dropped edges in the Xtion's view %.0f %% at 2 m, %.0f %% at (%.2f, %.2f) (predicted %.0f %%, "
        "heights %.2f-%.2f m, %.0f %% at heights in reach)\n",
        r.camera->name.c_str(), 100.0 * share_before, 100.0 * share_after, region.robot_position.x(),
        region.robot_position.y(), 100.0 * region.xtion_share, region.structure_min_height_m,
        region.structure_max_height_m, 100.0 * region.xtionHeightShare());
    EXPECT_GE(share_after, share_before - 0.02) << r.camera->name;
    sum_before += share_before;
    sum_after += share_after;
    // The main region stands within the level Xtion's heights; without the view known nothing is said of it.
    EXPECT_GE(region.xtionHeightShare(), 0.9) << r.camera->name;
    EXPECT_NEAR(level.highestInReach(4.0), 1.0 + 4.0 * std::sin(20.5 * M_PI / 180.0), 1e-12);
    EXPECT_FALSE(region.outOfXtionReach(aware.min_xtion_share)) << r.camera->name;
    EXPECT_EQ(before.sentence().find("mount the Xtion"), std::string::npos);
  }
  EXPECT_GE(sum_after, sum_before + 0.3);  // 10 points per camera on average
}

// An Xtion low and tilted down sees no wall above knee height within its depth's reach: a region whose structure
// stands mostly higher says so, and what to do about it.
TEST_F(SurveyGuidanceTest, AnXtionThatCannotSeeTheStructureSaysSo)
{
  const ic::XtionView low{0.3, -20.0, 22.5, 29.0};  // nothing above 0.33 m within 4 m
  size_t told = 0;
  for (const RenderedCamera& r : *cameras_)
  {
    const HalfSurvey h = leftHalfUnmapped(*world_, r);
    ic::SurveyGuidanceOptions options;
    options.xtions.push_back(low);
    const auto g = ic::computeSurveyGuidance(r.camera->camera, r.camera->width, r.camera->height, r.lines, h.kept,
                                             options.tolerance_px, options);
    ASSERT_FALSE(g.regions.empty()) << r.camera->name;
    const size_t high =
        std::count_if(h.dropped.begin(), h.dropped.end(), [](const SeenEdge& e) { return e.middle.z() > 0.6; });
    const auto& region = g.regions.front();
    std::printf(
        "%s: %zu of %zu dropped edges above 0.6 m; region heights %.2f-%.2f m, %.0f %% at heights in reach: "
        "%s\n",
        r.camera->name.c_str(), high, h.dropped.size(), region.structure_min_height_m, region.structure_max_height_m,
        100.0 * region.xtionHeightShare(), g.sentence().c_str());
    // One piece of advice per region out of its reach, whole (not cut off).
    size_t out_of_reach = 0, says = 0;
    for (const auto& rg : g.regions)
      out_of_reach += rg.outOfXtionReach(options.min_xtion_share) ? 1 : 0;
    const std::string sentence = g.sentence();
    const std::string advice =
        " for a second drive, keeping the first one's recording, or calibrate this camera from CAD lines)";
    for (size_t at = sentence.find(advice); at != std::string::npos; at = sentence.find(advice, at + 1))
      ++says;
    EXPECT_EQ(says, out_of_reach) << r.camera->name;
    // A region above the Xtion is told the pitch that has the floor up to the camera's height in view.
    if (region.outOfXtionReach(options.min_xtion_share))
    {
      EXPECT_NEAR(region.camera_height_m, r.camera->camera.pose().center().z(), 1e-9);
      const auto pitch = low.pitchToSee(0.0, region.camera_height_m, 4.0);
      ASSERT_TRUE(pitch) << r.camera->name;
      char told[64];
      std::snprintf(told, sizeof(told), "pitch the Xtion to about %+.0f deg", std::round(*pitch));
      EXPECT_NE(sentence.find(told), std::string::npos) << sentence;
      // The hint file carries the same pitch, for a program to act on (generate_world --xtion-tilt advised).
      const ic::SurveyHint hint = ic::surveyHintOf(r.camera->name, g);
      ASSERT_TRUE(hint.regions.front().xtion_pitch_deg) << r.camera->name;
      EXPECT_EQ(*hint.regions.front().xtion_pitch_deg, std::round(*pitch));
    }
    const ic::SurveyHint hint = ic::surveyHintOf(r.camera->name, g);
    for (size_t k = 0; k < g.regions.size(); ++k)  // only regions out of reach carry a pitch
      EXPECT_TRUE(g.regions[k].outOfXtionReach(options.min_xtion_share) || !hint.regions[k].xtion_pitch_deg)
          << r.camera->name;
    if (region.outOfXtionReach(options.min_xtion_share))
      ++told;
  }
  EXPECT_GE(told, 1u);  // cam_desk's left half: mostly its far wall
}

// A survey driven at two mounts: a region the low one misses but the pitched-up one sees is in reach (nothing to
// advise), and a region both miss is advised from the mount that sees highest, for another drive.
TEST_F(SurveyGuidanceTest, ARegionIsOutOfReachOnlyWhenEveryMountMissesIt)
{
  const ic::XtionView low{0.3, -20.0, 22.5, 29.0};     // nothing above 0.33 m within 4 m
  const ic::XtionView up{0.3, 25.0, 22.5, 29.0};       // 0 to 3.3 m within 4 m
  const ic::XtionView lower{0.25, -25.0, 22.5, 29.0};  // nothing above 0.25 m
  size_t told = 0;
  for (const RenderedCamera& r : *cameras_)
  {
    const HalfSurvey h = leftHalfUnmapped(*world_, r);
    auto guide = [&](const std::vector<ic::XtionView>& xtions) {
      ic::SurveyGuidanceOptions options;
      options.xtions = xtions;
      return ic::computeSurveyGuidance(r.camera->camera, r.camera->width, r.camera->height, r.lines, h.kept,
                                       options.tolerance_px, options);
    };
    const auto alone = guide({low}), both = guide({low, up}), missed = guide({lower, low});
    ASSERT_FALSE(alone.regions.empty() || both.regions.empty() || missed.regions.empty()) << r.camera->name;
    const double min_share = ic::SurveyGuidanceOptions().min_xtion_share;
    if (!alone.regions.front().outOfXtionReach(min_share))
      continue;
    ++told;
    std::printf("%s: low mount alone: %s\nlower and low: %s\n", r.camera->name.c_str(), alone.sentence().c_str(),
                missed.sentence().c_str());
    EXPECT_FALSE(both.regions.front().outOfXtionReach(min_share)) << both.sentence();
    EXPECT_GE(both.regions.front().xtionHeightShare(), 0.9) << r.camera->name;
    EXPECT_EQ(both.sentence().find("pitch the Xtion"), std::string::npos) << both.sentence();
    const auto& region = missed.regions.front();
    ASSERT_TRUE(region.outOfXtionReach(min_share)) << missed.sentence();
    EXPECT_NEAR(region.xtion.pitch_deg, low.pitch_deg, 1e-12);  // the mount that sees highest
    const auto pitch = low.pitchToSee(0.0, region.camera_height_m, 4.0);
    ASSERT_TRUE(pitch) << r.camera->name;
    char advised[64];
    std::snprintf(advised, sizeof(advised), "pitch the Xtion to about %+.0f deg", std::round(*pitch));
    const std::string sentence = missed.sentence();
    EXPECT_NE(sentence.find(advised), std::string::npos) << sentence;
    EXPECT_NE(sentence.find("at the survey's 2 mounts (0.25 m high pitched -25 deg; 0.30 m high pitched -20 deg)"),
              std::string::npos)
        << sentence;
    EXPECT_NE(sentence.find(" for another drive, keeping the recordings so far, or calibrate"), std::string::npos)
        << sentence;
    EXPECT_EQ(sentence.find("second drive"), std::string::npos) << sentence;
  }
  EXPECT_GE(told, 1u);
}

// The pitch that brings a band of heights into the Xtion's view within reach: an Xtion 0.38 m high needs about
// +14 deg to have the floor and 2.6 m both in view within 4 m (the only pitches that do: their middle); one 1.23 m
// high pitched +12 deg sees the floor within 4 m from about 0 deg down; 5 m is beyond any pitch at 4 m.
TEST(XtionViewTest, PitchToSeeABandOfHeights)
{
  const ic::XtionView low{0.38, -13.7, 22.8, 29.0};
  EXPECT_LT(low.highestInReach(4.0), 1.0);
  const auto pitch = low.pitchToSee(0.0, 2.6, 4.0);
  ASSERT_TRUE(pitch);
  EXPECT_NEAR(*pitch, 14.1, 0.2);
  ic::XtionView pitched = low;
  pitched.pitch_deg = *pitch;
  EXPECT_GE(pitched.highestInReach(4.0), 2.6);
  EXPECT_LE(pitched.lowestInReach(4.0), 0.0);
  // The floor alone: the least change from its pitch that does it, 3 deg to spare.
  const ic::XtionView high{1.23, 12.0, 22.8, 29.0};
  const auto floor = high.pitchToSee(0.0, 0.0, 4.0);
  ASSERT_TRUE(floor);
  EXPECT_NEAR(*floor, 20.8 - std::asin(1.23 / 4.0) * 180.0 / M_PI - 3.0, 1e-9);
  ic::XtionView lowered = high;
  lowered.pitch_deg = *floor;
  EXPECT_LE(lowered.lowestInReach(4.0), 0.0);
  EXPECT_NEAR(*high.pitchToSee(1.0, 1.5, 4.0), 12.0, 1e-12);  // in view already: unchanged
  EXPECT_FALSE(low.pitchToSee(0.0, 5.0, 4.0));                // 4.6 m above it: out of reach at any pitch
  EXPECT_FALSE(low.pitchToSee(0.0, 3.9, 4.0));                // within reach, but not with the floor in the same view
  const auto up = low.pitchToSee(1.0, 3.9, 4.0);              // without the floor it can be done
  ASSERT_TRUE(up);
  pitched.pitch_deg = *up;
  EXPECT_GE(pitched.highestInReach(4.0), 3.9);
}

namespace
{
// A region above the Xtion (80 % of what it shows higher than the survey's mount sees), out of its reach.
ic::UnmappedRegion regionAbove(const ic::XtionView& xtion, double top_m, double camera_height_m)
{
  ic::UnmappedRegion r;
  r.where = "centre";
  r.image_lines = 40;
  r.xtion = xtion;
  r.xtions = {xtion};
  r.xtion_reach_m = 4.0;
  r.xtion_share = 0.01;
  r.xtion_above_share = 0.8;
  r.structure_max_height_m = top_m;
  r.camera_height_m = camera_height_m;
  return r;
}
}  // namespace

// A hall's camera 4.6 m high over an Xtion 0.67 m high: no pitch within 45 deg has the heights it misses in view at
// its height; the lowest mount that does is 1.1 m high pitched +44 deg (at 1.0 m it would take +47), and it adds what
// the survey's mount misses without a gap. A pitch alone keeps the height (none in the hint); nothing within the
// limits: the sentence says what is beyond them.
TEST(XtionViewTest, AMountHigherWhereNoPitchDoes)
{
  const ic::XtionView survey_mount{0.67, 3.0, 22.5, 29.0};
  const ic::UnmappedRegion hall = regionAbove(survey_mount, 4.6, 4.6);
  const auto mount = hall.mountToSee();
  ASSERT_TRUE(mount);
  EXPECT_NEAR(mount->height_m, 1.1, 1e-9);
  EXPECT_EQ(mount->pitch_deg, 44.0);
  ic::XtionView mounted = survey_mount;
  mounted.height_m = mount->height_m;
  mounted.pitch_deg = mount->pitch_deg;
  EXPECT_GE(mounted.highestInReach(4.0), 4.6);
  EXPECT_LE(mounted.lowestInReach(4.0), survey_mount.highestInReach(4.0));
  const auto from_one_metre = regionAbove({1.0, 3.0, 22.5, 29.0}, 4.6, 4.6).mountToSee();  // +47 at its own height
  ASSERT_TRUE(from_one_metre);
  EXPECT_NEAR(from_one_metre->height_m, 1.1, 1e-9);
  ic::SurveyGuidance g;
  g.regions = {hall};
  EXPECT_NE(g.sentence().find("mount the Xtion about 1.1 m high and pitch it to about +44 deg"), std::string::npos)
      << g.sentence();
  const ic::SurveyHint hint = ic::surveyHintOf("cam_b", g);
  ASSERT_TRUE(hint.regions.front().xtion_pitch_deg && hint.regions.front().xtion_height_m);
  EXPECT_EQ(*hint.regions.front().xtion_pitch_deg, 44.0);
  EXPECT_NEAR(*hint.regions.front().xtion_height_m, 1.1, 1e-9);

  const ic::UnmappedRegion room = regionAbove({0.38, -13.7, 22.8, 29.0}, 2.0, 2.6);
  const auto pitched = room.mountToSee();
  ASSERT_TRUE(pitched);
  EXPECT_EQ(pitched->height_m, 0.38);
  EXPECT_EQ(pitched->pitch_deg, std::round(*room.xtion.pitchToSee(0.0, 2.6, 4.0)));
  g.regions = {room};
  EXPECT_FALSE(ic::surveyHintOf("cam_a", g).regions.front().xtion_height_m);
  EXPECT_NE(g.sentence().find("pitch the Xtion to about +14 deg"), std::string::npos) << g.sentence();

  g.regions = {regionAbove(survey_mount, 9.0, 9.5)};  // from 6 m up, 4.5 m above 1.5 m: no mount within the limits
  g.regions.front().structure_min_height_m = 6.0;
  EXPECT_FALSE(g.regions.front().mountToSee());
  EXPECT_NE(g.sentence().find("mount the Xtion higher than 1.5 m (or pitched more than 45 deg)"), std::string::npos)
      << g.sentence();
}

namespace
{
// A keyframe 640 x 480 at 525 px, at (x, 2, z), the robot facing yaw_deg with the camera pitched pitch_deg.
ic::Keyframe keyframeAt(double x, double z, double yaw_deg, double pitch_deg)
{
  ic::Keyframe kf;
  kf.focal_px = 525.0;
  kf.image_width = 640;
  kf.image_height = 480;
  const double yaw = yaw_deg * M_PI / 180.0, pitch = pitch_deg * M_PI / 180.0;
  const Eigen::Matrix3d base =
      (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  Eigen::Matrix3d optical;
  optical << 0, 0, 1, -1, 0, 0, 0, -1, 0;  // optical axes in the base frame: x right = -y, y down = -z, z = x
  kf.T_map_camera.linear() = base * optical;
  kf.T_map_camera.translation() = Eigen::Vector3d(x, 2.0, z);
  return kf;
}
}  // namespace

// The Xtion's views from keyframes, one per mount: the median height above the floor and pitch of each group of
// keyframes at one mount, the field of view from the image; a mount driven again adds none, a mount changed within a
// recording (the node's survey going on after a re-tilt) adds one, a moment's tilt (a threshold) none.
TEST(XtionViewTest, FromKeyframesOnePerMount)
{
  EXPECT_TRUE(ic::xtionViewsOf({}, 0.0).empty());
  std::vector<ic::Keyframe> keyframes;
  for (int k = 0; k < 5; ++k)
    keyframes.push_back(keyframeAt(k, 0.1 + 0.8, 30.0 * k, -12.0));
  auto views = ic::xtionViewsOf(keyframes, 0.1);
  ASSERT_EQ(views.size(), 1u);
  EXPECT_NEAR(views[0].height_m, 0.8, 1e-9);
  EXPECT_NEAR(views[0].pitch_deg, -12.0, 1e-9);
  EXPECT_NEAR(views[0].vertical_half_fov_deg, std::atan(240.0 / 525.0) * 180.0 / M_PI, 1e-9);
  EXPECT_NEAR(views[0].horizontal_half_fov_deg, std::atan(320.0 / 525.0) * 180.0 / M_PI, 1e-9);
  // A second recording re-pitched to +10 deg, a third at the first's mount (1 deg, 2 cm off), two keyframes tilted
  // +4 deg for a moment (a threshold).
  for (int recording = 0; recording < 2; ++recording)
    for (int k = 0; k < 5; ++k)
    {
      keyframes.push_back(recording == 0 ? keyframeAt(k, 0.9, 45.0 * k, 10.0) : keyframeAt(k, 0.92, -20.0 * k, -11.0));
      keyframes.back().starts_recording = k == 0;
    }
  keyframes.push_back(keyframeAt(3.0, 0.9, 0.0, -8.0));
  keyframes.push_back(keyframeAt(3.1, 0.9, 0.0, -8.0));
  views = ic::xtionViewsOf(keyframes, 0.1);
  ASSERT_EQ(views.size(), 2u);
  EXPECT_NEAR(views[0].pitch_deg, -12.0, 1.0);   // the first and third recordings' keyframes
  EXPECT_NEAR(views[0].height_m, 0.81, 0.0101);  // 0.8 or 0.82: the median of both
  EXPECT_NEAR(views[1].height_m, 0.8, 1e-9);
  EXPECT_NEAR(views[1].pitch_deg, 10.0, 1e-9);
  // One recording whose Xtion is raised 20 cm half-way, pitch unchanged: two mounts.
  std::vector<ic::Keyframe> raised;
  for (int k = 0; k < 10; ++k)
    raised.push_back(keyframeAt(k, k < 5 ? 0.6 : 0.8, 36.0 * k, 5.0));
  views = ic::xtionViewsOf(raised, 0.0);
  ASSERT_EQ(views.size(), 2u);
  EXPECT_NEAR(views[0].height_m, 0.6, 1e-9);
  EXPECT_NEAR(views[1].height_m, 0.8, 1e-9);
}

// The reach of the survey's depth lines for the map: the first 0.25 m band from the Xtion in which fewer than half of
// them are precise enough (the Xtion's noise grows as z^2); none while every band is; a band of too few lines does
// not end it. surveyGuidanceOptions takes it, and keeps the option's where the survey shows none.
TEST(XtionViewTest, TheDepthLinesReachWhereMostAreStillPreciseEnough)
{
  // Lines every centimetre from 1.5 to 5 m, their sigma 3 mm at 3.1 m and growing as the range squared.
  auto keyframesTo = [](double farthest_m) {
    std::vector<ic::Keyframe> keyframes(2, keyframeAt(0.0, 0.9, 0.0, 0.0));
    for (int k = 150; k <= static_cast<int>(std::round(100.0 * farthest_m)); ++k)
    {
      ic::KeyframeLine l;
      l.line.range_m = 0.01 * k;
      l.line.sigma_m = 0.003 * std::pow(l.line.range_m / 3.1, 2.0);
      keyframes[k % 2].lines.push_back(l);
    }
    return keyframes;
  };
  const auto reach = ic::depthLineReach(keyframesTo(5.0), 0.003);
  ASSERT_TRUE(reach);
  EXPECT_NEAR(*reach, 3.0, 1e-9);                                         // [3.0, 3.25 m): 11 of 25 lines within 3 mm
  EXPECT_NEAR(*ic::depthLineReach(keyframesTo(5.0), 0.0048), 4.0, 1e-9);  // 4.8 mm at 3.92 m: 18 of 25 below 4 m
  EXPECT_FALSE(ic::depthLineReach(keyframesTo(3.0), 0.003));              // the scene ends first
  EXPECT_FALSE(ic::depthLineReach({}, 0.003));
  auto few = keyframesTo(3.0);
  for (int k = 0; k < static_cast<int>(ic::kMinReachBandLines) - 1; ++k)
  {
    ic::KeyframeLine far;
    far.line.range_m = 4.1;
    far.line.sigma_m = 0.02;
    few[0].lines.push_back(far);
  }
  EXPECT_FALSE(ic::depthLineReach(few, 0.003));

  const auto options = ic::surveyGuidanceOptions(keyframesTo(5.0), 0.0, 0.003);
  EXPECT_NEAR(options.xtion_reach_m, 3.0, 1e-9);
  EXPECT_EQ(options.xtions.size(), 1u);
  ic::SurveyGuidanceOptions given;
  given.xtion_reach_m = 3.5;
  EXPECT_NEAR(ic::surveyGuidanceOptions(keyframesTo(3.0), 0.0, 0.003, given).xtion_reach_m, 3.5, 1e-9);
}

// A depth reach too short for any mount within the limits to have all of a high wall's heights in view: the mount
// pitched to the limit that adds a useful part of them is advised, and the sentence says what it then has in view; a
// region whose heights it does not reach at all gets none.
TEST(XtionViewTest, APartOfAHighWallWhereNoMountHasItAll)
{
  const ic::XtionView survey_mount{0.67, 3.0, 22.5, 29.0};
  ic::UnmappedRegion hall = regionAbove(survey_mount, 4.6, 4.6);
  hall.xtion_reach_m = 3.0;
  const auto mount = hall.mountToSee();
  ASSERT_TRUE(mount);
  EXPECT_NEAR(mount->height_m, 0.67, 1e-9);  // no higher mount has it all either: the Xtion's own height
  EXPECT_LE(std::abs(mount->pitch_deg), 45.0);
  ic::XtionView mounted = survey_mount;
  mounted.pitch_deg = mount->pitch_deg;
  EXPECT_GE(mounted.highestInReach(3.0), survey_mount.highestInReach(3.0) + ic::kMinAdvisedBandM);
  EXPECT_LT(mounted.highestInReach(3.0), 4.6);                              // a part only
  EXPECT_LE(mounted.lowestInReach(3.0), survey_mount.highestInReach(3.0));  // next to what the survey has
  ic::SurveyGuidance g;
  g.regions = {hall};
  char advised[96];
  std::snprintf(advised, sizeof(advised), "pitch the Xtion to about %+.0f deg (it then has", mount->pitch_deg);
  EXPECT_NE(g.sentence().find(advised), std::string::npos) << g.sentence();
  hall.structure_min_height_m = 4.2;  // all above what a mount within the limits reaches within 3 m
  EXPECT_FALSE(hall.mountToSee());
}

// A whole view unmapped, from under the camera to the far wall, is more than one standpoint of an Xtion with a short
// reach has in view: the region is cut in parts, each with its own standpoint, and together they have more of the
// view's edges in view than the one standpoint had; the parts hold the region's cells and image lines.
TEST_F(SurveyGuidanceTest, AWholeViewBeyondOneStandpointGetsOnePerPart)
{
  const ic::XtionView level{1.0, 0.0, 22.5, 29.0};
  double gained = 0.0;
  int cut_views = 0;
  for (const RenderedCamera& r : *cameras_)
  {
    const auto nothing = outOfView(*world_, r.camera->camera, r.camera->width, r.camera->height);
    ic::SurveyGuidanceOptions one, parts;
    one.xtions.push_back(level);
    one.xtion_reach_m = 2.75;
    one.max_region_parts = 1;
    parts = one;
    parts.max_region_parts = 4;
    const auto& c = *r.camera;
    const auto whole = ic::computeSurveyGuidance(c.camera, c.width, c.height, r.lines, nothing, one.tolerance_px, one);
    const auto cut =
        ic::computeSurveyGuidance(c.camera, c.width, c.height, r.lines, nothing, parts.tolerance_px, parts);
    ASSERT_EQ(whole.regions.size(), 1u) << c.name;
    ASSERT_GE(cut.regions.size(), 1u) << c.name;
    ASSERT_LE(cut.regions.size(), 4u) << c.name;
    std::vector<int> cells;
    size_t lines = 0;
    for (const auto& region : cut.regions)
    {
      cells.insert(cells.end(), region.cells.begin(), region.cells.end());
      lines += region.image_lines;
      EXPECT_GT(region.image_lines, 0u) << c.name;
    }
    std::sort(cells.begin(), cells.end());
    EXPECT_EQ(cells, whole.regions.front().cells) << c.name;
    EXPECT_EQ(lines, whole.regions.front().image_lines) << c.name;
    const double before = shareInAnyStandpointsView(r.edges, whole, level, one.look_sweep_deg, 2.75);
    const double after = shareInAnyStandpointsView(r.edges, cut, level, one.look_sweep_deg, 2.75);
    std::printf(
        "%s: %zu part(s); the view's edges in the Xtion's view %.0f %% from one standpoint (predicted %.0f %%), "
        "%.0f %% from the parts'\n",
        c.name.c_str(), cut.regions.size(), 100.0 * before, 100.0 * whole.regions.front().xtion_share, 100.0 * after);
    if (whole.regions.front().xtion_share >= parts.split_below_share)
      EXPECT_EQ(cut.regions.size(), 1u) << c.name;
    EXPECT_GE(after, before - 0.02) << c.name;
    gained += after - before;
    cut_views += cut.regions.size() > 1 ? 1 : 0;
  }
  EXPECT_GE(cut_views, 1);
  EXPECT_GE(gained, 0.05);  // cam_wide: 7 % of its view's edges from one standpoint, 16 % from two
}
