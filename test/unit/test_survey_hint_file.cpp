// The survey hint file (survey_hint_file.h): what calibrate_survey writes for a refused camera reads back the same,
// is plain YAML that yaml-cpp reads, and a broken file is refused with its place; the store writes it atomically
// and a saved calibration removes it.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include <yaml-cpp/yaml.h>

#include "insitu_calibration/io/atomic_file.h"
#include "insitu_calibration/io/calibration_store.h"
#include "insitu_calibration/survey/survey_hint_file.h"

namespace ic = insitu_calibration;
namespace fs = std::filesystem;

namespace
{
// Guidance with two regions, as computeSurveyGuidance leaves it.
ic::SurveyGuidance twoRegions()
{
  ic::SurveyGuidance g;
  g.width = 1280;
  g.height = 720;
  g.columns = 8;
  g.rows = 6;
  ic::UnmappedRegion left;
  left.where = "left";
  left.image_lines = 29;
  left.robot_position = Eigen::Vector2d(16.7123, 0.4456);
  left.look_direction = Eigen::Vector2d(-0.97, -0.23).normalized();
  left.floor_polygon = {{14.0, -1.0}, {15.5, -1.2}, {15.9, 2.25}, {13.1, 1.0}};
  ic::UnmappedRegion top;
  top.where = "top right";
  top.image_lines = 3;
  top.robot_position = Eigen::Vector2d(-2.0, 5.5);
  top.look_direction = Eigen::Vector2d(0.0, 1.0);
  top.floor_polygon = {{-3.0, 7.0}, {-1.0, 7.0}, {-2.0, 8.0}};
  top.xtion_share = 0.125;  // the Xtion's view known for this one
  top.structure_min_height_m = 1.1;
  top.structure_max_height_m = 2.87;
  g.regions = {left, top};
  return g;
}
}  // namespace

TEST(SurveyHintFile, RoundTripKeepsEveryRegionToTheMillimetre)
{
  const ic::SurveyGuidance guidance = twoRegions();
  const std::string text = ic::surveyHintYaml(ic::surveyHintOf("cam_a", guidance));
  const auto hint = ic::parseSurveyHint(text);
  ASSERT_TRUE(hint) << hint.error().describe();
  EXPECT_EQ(hint->camera, "cam_a");
  EXPECT_EQ(hint->image_width, 1280);
  EXPECT_EQ(hint->image_height, 720);
  ASSERT_EQ(hint->regions.size(), 2u);
  for (size_t k = 0; k < 2; ++k)
  {
    const ic::UnmappedRegion& want = guidance.regions[k];
    const ic::SurveyHintRegion& got = hint->regions[k];
    EXPECT_EQ(got.where, want.where);
    EXPECT_EQ(got.image_lines, want.image_lines);
    EXPECT_LT((got.standpoint - want.robot_position).norm(), 1e-3);
    EXPECT_LT((got.look_direction - want.look_direction).norm(), 1e-4);
    EXPECT_NEAR(got.look_direction.norm(), 1.0, 1e-12);
    ASSERT_EQ(got.floor_polygon.size(), want.floor_polygon.size());
    for (size_t i = 0; i < want.floor_polygon.size(); ++i)
      EXPECT_LT((got.floor_polygon[i] - want.floor_polygon[i]).norm(), 1e-3);
    EXPECT_NEAR(got.xtion_share, want.xtion_share, 0.006);  // two decimals; -1 (not in the file) kept
    EXPECT_NEAR(got.structure_height_m.x(), k ? 1.1 : 0.0, 0.006);
    EXPECT_NEAR(got.structure_height_m.y(), k ? 2.87 : 0.0, 0.006);
  }
  EXPECT_EQ(text.find("xtion_share"), text.rfind("xtion_share"));  // only the region that has it
  // Plain YAML: yaml-cpp's own reader sees the same numbers.
  const YAML::Node doc = YAML::Load(text);
  EXPECT_EQ(doc["frame"].as<std::string>(), "map");
  EXPECT_NEAR(doc["regions"][0]["standpoint"][0].as<double>(), 16.712, 1e-9);
  EXPECT_EQ(doc["regions"][1]["where"].as<std::string>(), "top right");
  EXPECT_EQ(doc["regions"][0]["floor_polygon"].size(), 4u);
  // No region (nothing to survey): an empty list, read back as such.
  const auto none = ic::parseSurveyHint(ic::surveyHintYaml(ic::surveyHintOf("cam_b", ic::SurveyGuidance{})));
  ASSERT_TRUE(none) << none.error().describe();
  EXPECT_TRUE(none->regions.empty());
}

// The mount advice's pitch: written only for the regions that carry one, read back, and one pitch for a survey
// that follows several hints (the one that serves most of their image lines).
TEST(SurveyHintFile, ThePitchOfTheMountAdviceIsKeptAndOnePitchChosen)
{
  ic::SurveyHint hint = ic::surveyHintOf("cam_a", twoRegions());
  hint.regions[1].xtion_pitch_deg = 8.0;
  const std::string text = ic::surveyHintYaml(hint);
  EXPECT_EQ(text.find("xtion_pitch_deg"), text.rfind("xtion_pitch_deg"));
  const auto read = ic::parseSurveyHint(text);
  ASSERT_TRUE(read) << read.error().describe();
  EXPECT_FALSE(read->regions[0].xtion_pitch_deg);
  ASSERT_TRUE(read->regions[1].xtion_pitch_deg);
  EXPECT_EQ(*read->regions[1].xtion_pitch_deg, 8.0);
  std::string broken = text;
  broken.replace(broken.find("xtion_pitch_deg: 8"), 18, "xtion_pitch_deg: 120");
  const auto refused = ic::parseSurveyHint(broken, "hint.yaml");
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message().find("regions[1].xtion_pitch_deg"), std::string::npos)
      << refused.error().message();

  EXPECT_FALSE(ic::advisedXtionMount({}));
  EXPECT_FALSE(ic::advisedXtionMount({ic::surveyHintOf("cam_a", twoRegions())}));  // no region carries one
  ic::SurveyHint other = hint;
  other.regions[0].xtion_pitch_deg = -5.0;
  other.regions[1].xtion_pitch_deg = 14.0;
  ASSERT_TRUE(ic::advisedXtionMount({hint, other}));
  // Of 8 (3 image lines), -5 (29) and 14 (3): the mount that serves most lines, not the middle pitch.
  EXPECT_EQ(ic::advisedXtionMount({hint, other})->pitch_deg, -5.0);
  EXPECT_FALSE(ic::advisedXtionMount({hint, other})->height_m);  // the Xtion's own height
  EXPECT_EQ(ic::advisedXtionMount({hint})->pitch_deg, 8.0);
  other.regions[0].xtion_pitch_deg = 30.0;  // 5 lines at 30 deg; 8 and 12 deg (3 lines each) are one mount
  other.regions[0].image_lines = 5;
  other.regions[1].xtion_pitch_deg = 12.0;
  EXPECT_EQ(ic::advisedXtionMount({hint, other})->pitch_deg, 8.0);  // 6 lines (the first of 8 and 12)
}

// A mount advice that needs another height: the height is written beside its pitch, read back, and comes with the
// pitch chosen for the survey; a height without a pitch, or not a height, is refused with its place.
TEST(SurveyHintFile, TheHeightOfTheMountAdviceGoesWithItsPitch)
{
  ic::SurveyHint hint = ic::surveyHintOf("cam_a", twoRegions());
  hint.regions[0].xtion_pitch_deg = 25.0;
  hint.regions[0].xtion_height_m = 1.3;
  hint.regions[1].xtion_pitch_deg = 10.0;
  const std::string text = ic::surveyHintYaml(hint);
  EXPECT_EQ(text.find("xtion_height_m"), text.rfind("xtion_height_m"));
  const auto read = ic::parseSurveyHint(text);
  ASSERT_TRUE(read) << read.error().describe();
  ASSERT_TRUE(read->regions[0].xtion_height_m);
  EXPECT_NEAR(*read->regions[0].xtion_height_m, 1.3, 1e-12);
  EXPECT_FALSE(read->regions[1].xtion_height_m);

  ic::SurveyHint third = hint;
  third.regions[0].xtion_pitch_deg = 30.0;
  third.regions[0].xtion_height_m = 1.5;
  third.regions[1].xtion_pitch_deg = 12.0;
  // 25 deg at 1.3 m (29 lines), 10 (3), 30 deg at 1.5 m (29), 12 (3): another height is another mount; the first of
  // equals.
  const auto mount = ic::advisedXtionMount({hint, third});
  ASSERT_TRUE(mount);
  EXPECT_EQ(mount->pitch_deg, 25.0);
  ASSERT_TRUE(mount->height_m);
  EXPECT_NEAR(*mount->height_m, 1.3, 1e-12);
  third.regions[0].xtion_pitch_deg = 5.0;  // 25 at 1.3 m (29), then 10, 5, 12 at the Xtion's own height: 10 serves 35
  third.regions[0].xtion_height_m.reset();
  EXPECT_EQ(ic::advisedXtionMount({hint, third})->pitch_deg, 10.0);
  EXPECT_FALSE(ic::advisedXtionMount({hint, third})->height_m);

  for (const auto& [from, to] :
       std::vector<std::pair<std::string, std::string>>{{"    xtion_pitch_deg: 25\n", ""},
                                                        {"xtion_height_m: 1.30", "xtion_height_m: -1"},
                                                        {"xtion_height_m: 1.30", "xtion_height_m: high"}})
  {
    std::string broken = text;
    broken.replace(broken.find(from), from.size(), to);
    const auto refused = ic::parseSurveyHint(broken, "hint.yaml");
    ASSERT_FALSE(refused) << broken;
    EXPECT_NE(refused.error().message().find("regions[0].xtion_"), std::string::npos) << refused.error().message();
  }
}

TEST(SurveyHintFile, BrokenFilesAreRefusedWithTheirPlace)
{
  const std::string good = ic::surveyHintYaml(ic::surveyHintOf("cam_a", twoRegions()));
  const auto without = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    text.replace(text.find(from), from.size(), to);
    return ic::parseSurveyHint(text, "hint.yaml");
  };
  const auto no_stand = without("standpoint: [16.712, 0.446]", "stand: [16.712, 0.446]");
  ASSERT_FALSE(no_stand);
  EXPECT_NE(no_stand.error().message().find("regions[0].standpoint"), std::string::npos) << no_stand.error().message();
  const auto zero = without("look_direction: [0.0000, 1.0000]", "look_direction: [0, 0]");
  ASSERT_FALSE(zero);
  EXPECT_NE(zero.error().message().find("regions[1].look_direction"), std::string::npos) << zero.error().message();
  EXPECT_FALSE(without("standpoint: [16.712, 0.446]", "standpoint: [16.712]"));
  const auto share = without("xtion_share: 0.12", "xtion_share: 1.5");
  ASSERT_FALSE(share);
  EXPECT_NE(share.error().message().find("regions[1].xtion_share"), std::string::npos) << share.error().message();
  EXPECT_FALSE(without("structure_height_m: [1.10, 2.87]", "structure_height: [1.10, 2.87]"));
  EXPECT_FALSE(ic::parseSurveyHint("camera: cam_a\n", "hint.yaml"));
  EXPECT_FALSE(ic::parseSurveyHint("regions: [[", "hint.yaml"));
  EXPECT_FALSE(ic::readSurveyHint("/nonexistent/cam_a_survey_hint.yaml"));
}

TEST(SurveyHintFile, StoreWritesItAtomicallyAndASavedCalibrationRemovesIt)
{
  const fs::path dir = fs::temp_directory_path() / ("survey_hint_file_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const ic::CalibrationStore store(dir.string());
  const std::string text = ic::surveyHintYaml(ic::surveyHintOf("cam_a", twoRegions()));
  ASSERT_TRUE(store.saveSurveyHintYaml("cam_a", text));
  EXPECT_EQ(store.surveyHintYamlPath("cam_a"), (dir / "cam_a_survey_hint.yaml").string());
  const auto read = ic::readSurveyHint(store.surveyHintYamlPath("cam_a"));
  ASSERT_TRUE(read) << read.error().describe();
  EXPECT_EQ(read->regions.size(), 2u);
  // Nothing but the file itself is left in the directory (no temporary).
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    files += entry.is_regular_file() ? 1 : 0;
  EXPECT_EQ(files, 1u);
  // A killed write's temporary is stale.
  ASSERT_TRUE(ic::writeFileAtomically((dir / "cam_a_survey_hint.yaml.tmp.AbC123").string(), "x"));
  EXPECT_EQ(store.removeStaleTemporaries({"cam_a"}).size(), 1u);
  // A calibration saved supersedes the refusal.
  ic::CalibrationFile calibration;
  calibration.camera_name = "cam_a";
  calibration.image_width = 640;
  calibration.image_height = 480;
  ic::Intrinsics k;
  k.fx = k.fy = 500.0;
  k.cx = 320.0;
  k.cy = 240.0;
  ic::DivisionModel distortion;
  distortion.center = Eigen::Vector2d(320.0, 240.0);
  calibration.camera = ic::CameraModel(k, distortion, ic::CameraPose());
  const ic::Status saved = store.save("cam_a", calibration, cv::Mat());
  ASSERT_TRUE(saved) << saved.error().describe();
  EXPECT_FALSE(fs::exists(store.surveyHintYamlPath("cam_a")));
  fs::remove_all(dir);
}
