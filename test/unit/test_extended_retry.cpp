// A camera the map in use refuses is tried once more against the map with its extensions
// (calibrateWithExtendedRetry, SurveyOptions::extended_retry): the default world's cam_east rendered, the map in use
// a few of the true edges it sees (too few to calibrate), the extended map all of them. The retry calibrates it
// within the node's test thresholds and says so; a camera the map in use calibrates never builds the extended map;
// a retry that fails too keeps the first refusal and its advice, with the second reason noted; the ambiguity test's
// refusal is not retried.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/io/correspondence_file.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/survey/survey.h"
#include "insitu_calibration/survey/view_ambiguity.h"
#include "insitu_calibration/test_support/edges_in_view.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const std::string kWorld = std::string(INSITU_SOURCE_DIR) + "/config/worlds/waiting_room.yaml";

ic::CalibrationMap mapOf(const std::vector<ic::Segment3d>& segments, bool extended)
{
  ic::CalibrationMap map;
  map.segments = segments;
  map.sigmas.assign(segments.size(), 0.001);
  map.lines.resize(segments.size());
  map.extended = extended;
  return map;
}

class ExtendedRetryTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    auto world = sim::loadWorldFile(kWorld);
    ASSERT_TRUE(world) << world.error().describe();
    world_ = std::make_unique<sim::World>(*world);
    for (const auto& cam : world_->fixed_cameras)
      if (cam.name == "cam_east")
        cam_ = &cam;
    ASSERT_NE(cam_, nullptr);
    const sim::Renderer renderer(*world_);
    const auto view = renderer.render(sim::ViewCamera::fromModel(cam_->camera, cam_->width, cam_->height));
    cv::cvtColor(view.rgb, grey_, cv::COLOR_RGB2GRAY);
    edges_ = ic::edgesSeenInView(*world_, cam_->camera, view);
    ASSERT_GE(edges_.size(), 12u);
  }

  ic::FixedCamera camera() const
  {
    ic::FixedCameraConfig config;
    config.name = cam_->name;
    config.image_topic = "/" + cam_->name + "/image_raw";
    config.image_width = cam_->width;
    config.image_height = cam_->height;
    ic::CameraPrior prior;  // the installer's prior, near the truth
    prior.position = cam_->camera.pose().center() + Eigen::Vector3d(0.1, -0.1, 0.05);
    prior.direction = cam_->camera.pose().rotation.row(2).transpose();
    prior.horizontal_fov_deg = 2.0 * std::atan(0.5 * cam_->width / cam_->camera.intrinsics().fx) * 180.0 / M_PI;
    config.prior = prior;
    // A near prior: one search start and no ambiguity test are enough here, and keep the test short.
    ic::FixedCameraOptions options;
    options.matcher.search_starts = 1;
    options.matcher.hypothesis_starts = 0;
    options.matcher.local_search_starts = 1;
    options.ambiguity.enabled = false;
    ic::FixedCamera camera(config, options);
    EXPECT_TRUE(camera.addImage(grey_));
    return camera;
  }

  std::vector<ic::Segment3d> fewEdges() const { return {edges_.begin(), edges_.begin() + 3}; }

  // The retry from map_in_use with every seen edge as the extended map, counting how often that map is built.
  ic::Expected<ic::FixedCameraResult> retryOnAllEdges(const std::vector<ic::Segment3d>& map_in_use, int* built,
                                                      ic::CalibrationMap* used) const
  {
    ic::FixedCamera fixed = camera();
    return ic::calibrateWithExtendedRetry(
        fixed, "map", mapOf(map_in_use, false),
        [&]() {
          ++*built;
          return mapOf(edges_, true);
        },
        used);
  }

  std::unique_ptr<sim::World> world_;
  const sim::SimulatedFixedCamera* cam_ = nullptr;
  cv::Mat grey_;
  std::vector<ic::Segment3d> edges_;
};
}  // namespace

TEST_F(ExtendedRetryTest, ARefusedCameraIsCalibratedOnTheExtendedMap)
{
  int built = 0;
  ic::CalibrationMap used;
  const auto result = retryOnAllEdges(fewEdges(), &built, &used);
  ASSERT_TRUE(result) << result.error().describe();
  EXPECT_EQ(built, 1);
  EXPECT_TRUE(used.extended);
  EXPECT_EQ(used.segments.size(), edges_.size());
  std::printf("%s\n", result->summary.c_str());
  EXPECT_NE(result->summary.find("on the map with its extensions"), std::string::npos);
  EXPECT_NE(result->summary.find("the map in use refused it (only "), std::string::npos);
  ASSERT_TRUE(result->file.quality);
  EXPECT_EQ(result->file.quality->extra.at("extended_map"), 1.0);
  const ic::CameraErrors e = ic::compareCameras(cam_->camera, result->calibration.camera);
  EXPECT_LT(std::abs(e.focal_relative), 0.01);
  EXPECT_LT(e.rotation_rad * 180.0 / M_PI, 0.5);
  EXPECT_LT(e.center_m, 0.03);
}

TEST_F(ExtendedRetryTest, ACameraTheMapInUseCalibratesNeverBuildsTheExtendedMap)
{
  int built = 0;
  ic::CalibrationMap used;
  const auto result = retryOnAllEdges(edges_, &built, &used);
  ASSERT_TRUE(result) << result.error().describe();
  EXPECT_EQ(built, 0);
  EXPECT_FALSE(used.extended);
  EXPECT_EQ(result->summary.find("extensions"), std::string::npos);
  EXPECT_EQ(result->file.quality->extra.count("extended_map"), 0u);
}

TEST_F(ExtendedRetryTest, ARetryThatFailsKeepsTheFirstRefusalAndNotesTheSecond)
{
  ic::FixedCamera fixed = camera();
  ic::CalibrationMap used;
  const auto refused = ic::calibrateWithExtendedRetry(
      fixed, "map", mapOf(fewEdges(), false),
      [&]() {
        return mapOf({edges_[0], edges_[1]}, true);
      },
      &used);
  ASSERT_FALSE(refused);
  EXPECT_FALSE(used.extended);
  const std::string message = refused.error().message();
  std::printf("%s\n", message.c_str());
  EXPECT_EQ(message.find("only "), 0u);
  EXPECT_NE(message.find("(tried again on the map with its extensions (fused uncertain depth lines, ceiling lines): "
                         "only "),
            std::string::npos);
  // No retry without an extended map (the option off), and none for a refusal it cannot turn.
  ic::FixedCamera again = camera();
  const auto plain =
      ic::calibrateWithExtendedRetry(again, "map", mapOf(fewEdges(), false), []() { return ic::CalibrationMap{}; });
  ASSERT_FALSE(plain);
  EXPECT_EQ(plain.error().message().find("tried again"), std::string::npos);
  EXPECT_FALSE(ic::extendedRetryWorthwhile(ic::Error(ic::ErrorCode::kInvalidInput, "unknown camera 'x'")));
  EXPECT_FALSE(
      ic::extendedRetryWorthwhile(ic::Error(ic::ErrorCode::kNotEnoughData, "no image has arrived from /x yet")));
  EXPECT_TRUE(ic::extendedRetryWorthwhile(ic::Error(ic::ErrorCode::kDegenerate, ic::kWeaklyDeterminedRefusal)));
  // Nor the ambiguity test's refusal: two cameras explain the image alike on the map in use, and the extended map's
  // less certain lines must not pick one (a repeating view was accepted a period off so).
  for (const char* ambiguity : {ic::kRepeatingViewRefusal, ic::kUndecidedViewRefusal})
  {
    const ic::Error refusal(ic::ErrorCode::kNoSolution, std::string(ambiguity) + ": a camera at 1 2 3 explains ...");
    EXPECT_TRUE(ic::isAmbiguityRefusal(refusal)) << ambiguity;
    EXPECT_FALSE(ic::extendedRetryWorthwhile(refusal)) << ambiguity;
  }
  EXPECT_TRUE(ic::extendedRetryWorthwhile(
      ic::Error(ic::ErrorCode::kNoSolution, "the camera does not explain the image: too few of the map lines ...")));
}

// A camera calibrated from its correspondence file (CAD lines) does not use the map: its refusal is not retried,
// and the extended map is not built for it.
TEST_F(ExtendedRetryTest, ACameraFromACorrespondenceFileIsNotRetried)
{
  ic::CorrespondenceSet two_lines;  // too few lines to calibrate
  two_lines.image_width = cam_->width;
  two_lines.image_height = cam_->height;
  for (size_t k = 0; k < 2; ++k)
  {
    ic::LineCorrespondence line;
    line.world = {edges_[k].a, edges_[k].b};
    line.image = {*cam_->camera.project(edges_[k].a), *cam_->camera.project(edges_[k].b)};
    two_lines.lines.push_back(line);
  }
  const std::string path = ::testing::TempDir() + "extended_retry_two_lines.yaml";
  ASSERT_TRUE(ic::saveCorrespondenceFile(path, two_lines));
  ic::FixedCameraConfig config = camera().config();
  config.correspondence_file = path;
  ic::FixedCamera fixed(config, ic::FixedCameraOptions());
  int built = 0;
  const auto refused = ic::calibrateWithExtendedRetry(fixed, "map", mapOf(edges_, false), [&]() {
    ++built;
    return mapOf(edges_, true);
  });
  ASSERT_FALSE(refused);
  std::printf("%s\n", refused.error().describe().c_str());
  EXPECT_TRUE(ic::extendedRetryWorthwhile(refused.error()));  // a map-based camera's refusal like it would be
  EXPECT_EQ(built, 0);
  EXPECT_EQ(refused.error().message().find("tried again"), std::string::npos);
}

TEST(ExtendedRetryOptions, TheExtendedMapAddsFusionAndCeilingLinesOnlyWhenMissing)
{
  ic::SurveyOptions options;
  EXPECT_TRUE(ic::extendedRetryAdds(options));  // on by default
  options.extended_retry.enabled = false;
  EXPECT_FALSE(ic::extendedRetryAdds(options));
  options.extended_retry.enabled = true;
  const ic::SurveyOptions extended = ic::extendedMapOptions(options);
  EXPECT_DOUBLE_EQ(extended.map.max_fusion_sigma_m, 0.012);
  EXPECT_TRUE(extended.ceiling.enabled);
  options.map.max_fusion_sigma_m = 0.02;
  options.ceiling.enabled = true;
  EXPECT_FALSE(ic::extendedRetryAdds(options));  // the map in use has both already
  EXPECT_DOUBLE_EQ(ic::extendedMapOptions(options).map.max_fusion_sigma_m, 0.02);
}
