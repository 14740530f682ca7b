// End to end on a procedural building (generate_world), without ROS: a small generated room surveyed for 30 s in
// memory, every fixed camera calibrated from the generated installer priors (0.5 m, 10 deg, 20 % off) exactly as
// the node and calibrate_survey do. Asserts what must hold in any building: no accepted camera is wrong (more than
// 5 % focal length, 2 deg or 10 cm off), every refusal says why, and (a regression guard for this one building)
// at least one camera is calibrated within the node's test thresholds (1 %, 0.5 deg, 3 cm).
#include <gtest/gtest.h>

#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/metrics.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/world_generator.h"
#include "insitu_calibration/survey/camera_config.h"
#include "insitu_calibration/survey/survey.h"
#include "insitu_calibration/test_support/simulated_survey.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
constexpr uint64_t kBuilding = 5;  // a room; seeds 2001-2010 are the README's benchmark set
constexpr double kDuration = 30.0;

}  // namespace

TEST(GeneratedSurvey, NoWrongCameraAcceptedInAGeneratedRoom)
{
  sim::WorldGeneratorOptions generator;
  generator.seed = kBuilding;
  generator.kind = sim::BuildingKind::kRoom;
  generator.max_route_s = kDuration;
  // The plain appearance this guard was tuned on. With the realistic default (materials, sensor effects) both
  // cameras of this room are refused (cam_a too weakly determined, cam_b 7 of 8 lines matched): no wrong camera, but
  // none within the thresholds either (measured when the appearance was added; docs/simulator.md).
  generator.realistic_appearance = false;
  const auto building = sim::generateWorld(generator);
  ASSERT_TRUE(building) << building.error().describe();
  const auto configs = ic::parseCameraConfig(building->cameras_yaml);
  ASSERT_TRUE(configs) << configs.error().describe();

  sim::SimulationOptions sim_options;
  sim_options.seed = 1;
  sim_options.duration_s = kDuration;
  auto simulator = sim::SurveySimulator::create(building->world, sim_options);
  ASSERT_TRUE(simulator) << simulator.error().describe();
  std::vector<ic::FixedCameraConfig> cameras;
  for (const auto& entry : *configs)
    cameras.push_back(entry.camera);
  ic::Survey survey(cameras);
  ic::test::feedSimulatedSurvey(*simulator, &survey);

  const auto map = survey.mapSegments();
  const auto sigmas = survey.mapLineSigmas();
  std::printf("%s: %zu keyframes, %zu map lines\n", building->world.name.c_str(), survey.stats().keyframes, map.size());
  int within_thresholds = 0;
  for (size_t c = 0; c < simulator->world().fixed_cameras.size(); ++c)
  {
    const std::string& name = simulator->world().fixed_cameras[c].name;
    const auto result = survey.camera(name).calibrate(map, "map", sigmas);
    if (!result)
    {
      std::printf("%s: refused: %s\n", name.c_str(), result.error().describe().c_str());
      EXPECT_GT(result.error().message().size(), 20u) << name;
      continue;
    }
    const ic::CameraErrors e =
        ic::compareCameras(simulator->groundTruth(static_cast<int>(c)).camera, result->calibration.camera);
    const double rotation_deg = e.rotation_rad * 180.0 / M_PI;
    std::printf("%s: focal %+.3f %%, rotation %.3f deg, position %.1f mm; %s\n", name.c_str(), 100.0 * e.focal_relative,
                rotation_deg, 1000.0 * e.center_m, result->explanation.describe().c_str());
    EXPECT_LT(std::abs(e.focal_relative), 0.05) << name << " accepted wrong";
    EXPECT_LT(rotation_deg, 2.0) << name << " accepted wrong";
    EXPECT_LT(e.center_m, 0.10) << name << " accepted wrong";
    within_thresholds += (std::abs(e.focal_relative) < 0.01 && rotation_deg < 0.5 && e.center_m < 0.03) ? 1 : 0;
  }
  EXPECT_GE(within_thresholds, 1);
}
