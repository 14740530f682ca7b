// Hostile inputs to every reader (issue 16): each is refused at once with an error naming the entry at fault, none
// throws, allocates beyond its file's size or hangs; and the calibration store keeps a restart harmless.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <random>

#include "insitu_calibration/calibration.h"
#include "insitu_calibration/io/atomic_file.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/io/calibration_store.h"
#include "insitu_calibration/io/correspondence_file.h"
#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/survey/camera_config.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;
namespace fs = std::filesystem;

namespace
{
const std::string kSource = INSITU_SOURCE_DIR;

std::string readText(const std::string& path)
{
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

fs::path freshDir(const std::string& name)
{
  const fs::path dir = fs::temp_directory_path() / ("insitu_robust_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void writeText(const fs::path& path, const std::string& text)
{
  std::ofstream(path) << text;
}

// The error of an Expected that must have failed, or a note that it did not.
template <typename T>
std::string errorOf(const ic::Expected<T>& e)
{
  return e ? std::string("(accepted)") : e.error().describe();
}

// A valid calibration of the example camera, and its text with one line replaced.
std::string exampleCalibrationText()
{
  return readText(kSource + "/config/examples/lobby_cam_truth.yaml");
}
std::string replaced(std::string text, const std::string& from, const std::string& to)
{
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

// Runs f within `seconds` or fails the test and ends the process (a hang must not hang the suite).
template <typename F>
void withinSeconds(double seconds, F&& f)
{
  auto done = std::async(std::launch::async, std::forward<F>(f));
  if (done.wait_for(std::chrono::duration<double>(seconds)) != std::future_status::ready)
  {
    ADD_FAILURE() << "did not return within " << seconds << " s";
    std::_Exit(1);
  }
  done.get();
}
}  // namespace

TEST(RobustCorrespondenceFile, ScalarEntriesAreNamed)
{
  const auto e = ic::parseCorrespondences("image_width: 640\nimage_height: 480\nlines:\n  - 5\n");
  ASSERT_FALSE(e);
  EXPECT_NE(e.error().message().find("lines[0]"), std::string::npos) << e.error().describe();
  const auto p = ic::parseCorrespondences("image_width: 640\nimage_height: 480\npoints: [[1, 2]]\n");
  ASSERT_FALSE(p);
  EXPECT_NE(p.error().message().find("points[0]"), std::string::npos) << p.error().describe();
  EXPECT_FALSE(ic::parseCorrespondences("? [a, b]\n: 1\nimage_width: 640\n"));
  EXPECT_FALSE(ic::parseCorrespondences("[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[["));
}

TEST(RobustCorrespondenceFile, AliasBombsAndCyclesAreRefusedAtOnce)
{
  // 60 kB that expand to 5000 lines of 2000 points each: before the limit 47 s and 325 MB to refuse.
  std::string points;
  for (int i = 0; i < 2000; ++i)
    points += (i ? ", [" : "[") + std::to_string(10 + i % 600) + ", " + std::to_string(10 + (i * 7) % 400) + "]";
  std::string bomb = "big: &big [" + points + "]\nline: &line {image: *big, world: [[0, 0, 1], [1, 0, 1]]}\n" +
                     "image_width: 640\nimage_height: 480\nlines: [*line";
  for (int i = 1; i < 5000; ++i)
    bomb += ", *line";
  bomb += "]\n";
  const auto start = std::chrono::steady_clock::now();
  const auto e = ic::parseCorrespondences(bomb);
  ASSERT_FALSE(e);
  EXPECT_NE(e.error().message().find("aliases"), std::string::npos) << e.error().describe();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
  const auto cycle = ic::parseCorrespondences("image_width: 640\nimage_height: 480\nlines: &x\n  - image: *x\n");
  EXPECT_FALSE(cycle);
}

TEST(RobustCorrespondenceFile, LimitsAndRangesAreChecked)
{
  const std::string line = "  - image: [[1, 2], [30, 40]]\n    world: [[0, 0, 1], [1, 0, 1]]\n";
  EXPECT_FALSE(ic::parseCorrespondences("image_width: 99999999\nimage_height: 480\nlines:\n" + line));
  const auto far = ic::parseCorrespondences(
      "image_width: 640\nimage_height: 480\nlines:\n  - image: [[1e155, 2], [3, 4]]\n    world: [[0, 0, 1]]\n");
  ASSERT_FALSE(far);
  EXPECT_NE(far.error().message().find("outside the image"), std::string::npos) << far.error().describe();
  EXPECT_FALSE(ic::parseCorrespondences(
      "image_width: 640\nimage_height: 480\nlines:\n  - image: [[1, 2], [3, 4]]\n    world: [[1e9, 0, 1]]\n"));
  std::string many = "image_width: 640\nimage_height: 480\nlines:\n";
  for (size_t i = 0; i <= ic::correspondence_limits::kMaxLines; ++i)
    many += "  - {image: [[1, 2], [3, 4]], world: [[0, 0, 1]]}\n";
  const auto too_many = ic::parseCorrespondences(many);
  ASSERT_FALSE(too_many);
  EXPECT_NE(too_many.error().message().find("more than the"), std::string::npos) << too_many.error().describe();
}

// The eigen-solvers get normalised input and bounded iterations: 1e155 px, reaching them without the reader's
// range check, is an error or a result at once, never an endless QZ.
TEST(RobustSolvers, ExtremeCoordinatesReturnPromptly)
{
  std::mt19937 rng(5);
  const ic::CameraModel camera = ic::randomCamera({}, rng);
  ic::SyntheticLineOptions options;
  options.lines = 12;
  ic::CorrespondenceSet data = ic::makeSyntheticLines(camera, 1280, 960, options, rng).data;
  for (const double value : {1e155, 1e200, 1e300})
  {
    ic::CorrespondenceSet extreme = data;
    extreme.lines[0].image[0].x() = value;
    for (const bool ransac : {false, true})
    {
      ic::CalibrationOptions calibration;
      calibration.ransac = ransac;
      withinSeconds(20.0, [&] { (void)ic::calibrateCamera(extreme, calibration); });
    }
  }
}

TEST(RobustFiles, DirectoriesAndEmptyNamesAreClearErrors)
{
  const fs::path dir = freshDir("dirs");
  const auto c = ic::loadCorrespondenceFile(dir.string());
  ASSERT_FALSE(c);
  EXPECT_NE(c.error().message().find("is a directory"), std::string::npos) << c.error().describe();
  EXPECT_FALSE(ic::loadCalibrationFile(dir.string()));
  const ic::Status empty = ic::writeFileAtomically("", "x");
  ASSERT_FALSE(empty);
  EXPECT_NE(empty.error().message().find("give a file name"), std::string::npos) << empty.error().describe();
  EXPECT_FALSE(ic::writeFileAtomically(dir.string(), "x"));
  EXPECT_FALSE(ic::readFile("/dev/zero", 1 << 20));
}

TEST(RobustCalibrationFile, BadContentIsRefusedAndNamed)
{
  const std::string good = exampleCalibrationText();
  ASSERT_TRUE(ic::parseCalibration(good)) << errorOf(ic::parseCalibration(good));
  const std::string division_scalar = replaced(
      replaced(
          replaced(replaced(good, "division_model:\n", "division_model: 5\n"), "  lambda: -2.52940599848251e-08\n", ""),
          "  center: [617.187466866338, 509.442430927916]\n", ""),
      "  plumb_bob_max_error_px: 0.081596424992558\n", "");
  const auto scalar = ic::parseCalibration(division_scalar);
  ASSERT_FALSE(scalar);
  EXPECT_NE(scalar.error().message().find("division_model"), std::string::npos) << scalar.error().describe();
  const auto zero_k = ic::parseCalibration(
      replaced(good, "[1398.02936576119, 0, 617.187466866338, 0, 1422.21848150394, 509.442430927916, 0, 0, 1]",
               "[0, 0, 0, 0, 0, 0, 0, 0, 0]"));
  ASSERT_FALSE(zero_k);
  EXPECT_NE(zero_k.error().message().find("focal"), std::string::npos) << zero_k.error().describe();
  EXPECT_FALSE(ic::parseCalibration(replaced(good, "lambda: -2.52940599848251e-08", "lambda: .nan")));
  const auto folds = ic::parseCalibration(replaced(good, "lambda: -2.52940599848251e-08", "lambda: 1e-5"));
  ASSERT_FALSE(folds);
  EXPECT_NE(folds.error().message().find("folds"), std::string::npos) << folds.error().describe();
  EXPECT_FALSE(ic::parseCalibration(
      replaced(good, "position: [0.467898416178819, 0.355164296104225, 2.7]", "position: [.inf, 0, 2.7]")));
  EXPECT_FALSE(ic::parseCalibration(good + "quality:\n  ? [1, 2]\n  : 3\n"));
  EXPECT_FALSE(ic::parseCalibration(replaced(good, "camera_pose:", "camera_pose: 3\nunused:")));
}

TEST(RobustWorldFile, IssueInputsAreRefusedWithTheirEntry)
{
  const std::string room = readText(kSource + "/config/worlds/waiting_room.yaml");
  ASSERT_TRUE(sim::parseWorld(room, "room.yaml"));
  ASSERT_TRUE(sim::parseWorld(readText(kSource + "/config/worlds/corridor.yaml"), "corridor.yaml"));
  const std::string floor = "polygon: [[0, 0, 0], [8, 0, 0], [8, 6, 0], [0, 6, 0]]";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {replaced(room, floor, "polygon: [[-1e8, 0, 0], [8, 0, 0], [8, 6, 0], [0, 6, 0]]"), "floor"},
      {replaced(room, "size: [1.2, 2.18]", "size: [1e9, 2.18]"), "door_frame"},
      {replaced(room, "cell: 0.5}", "cell: 1e-300}"), "floor"},
      {replaced(room, "rate: 0.2", "rate: 1e9"), "cam_east"},
      {replaced(room, "rate: 0.2", "rate: 1e-300"), "cam_east"},
      {replaced(room, "xtion:\n", "xtion:\n  width: 1000000000\n"), "xtion"},
      {replaced(room, "width: 1280", "width: 2000000000"), "cam_east"},
      {replaced(room, "lighting:", "[1, 2]: 3\nlighting:"), "room.yaml"},
  };
  for (const auto& [text, entry] : cases)
  {
    const auto world = sim::parseWorld(text, "room.yaml");
    ASSERT_FALSE(world) << entry;
    EXPECT_NE(world.error().message().find(entry), std::string::npos) << world.error().describe();
  }
  std::string ring;
  for (int i = 0; i < 2000; ++i)
    ring += (i ? ", [" : "[") + std::to_string(4 + 3 * std::cos(i * 1e-3)) + ", " +
            std::to_string(3 + 2 * std::sin(i * 1e-3)) + ", 1]";
  const auto many = sim::parseWorld(replaced(room, floor, "polygon: [" + ring + "]"), "room.yaml");
  ASSERT_FALSE(many);
  EXPECT_NE(many.error().message().find("vertices"), std::string::npos) << many.error().describe();
}

TEST(RobustCameraList, BadEntriesAreNamed)
{
  const std::string cameras = readText(kSource + "/config/cameras.yaml");
  ASSERT_TRUE(ic::parseCameraConfig(cameras));
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"name: cam_east", "name: [cam, east]"},
           {"image_width: 1280", "image_width: 2000000000"},
           {"    prior:\n      position: [7.45, 0.55, 2.55]", "    prior: 5\n    other:\n      position: [1, 2, 3]"}})
  {
    const auto e = ic::parseCameraConfig(replaced(cameras, from, to));
    ASSERT_FALSE(e) << to;
    EXPECT_NE(e.error().message().find("cameras[0]"), std::string::npos) << e.error().describe();
  }
  EXPECT_FALSE(ic::parseCameraConfig("cameras:\n  - 5\n"));
}

TEST(CalibrationStore, BadFilesAreSetAsideAndValidOnesLoaded)
{
  const fs::path dir = freshDir("store");
  const ic::CalibrationStore store(dir.string());
  const std::string good = exampleCalibrationText();
  writeText(dir / "good.yaml", good);
  writeText(dir / "corrupt.yaml", replaced(good, "division_model:\n", "division_model: 5\nx:\n"));
  writeText(dir / "corrupt.yaml.bad", "an earlier bad file, never overwritten");
  writeText(dir / "nan.yaml", replaced(good, "lambda: -2.52940599848251e-08", "lambda: .nan"));

  const auto loaded = store.load("good", 1280, 960);
  ASSERT_TRUE(loaded.calibration) << loaded.problem;
  EXPECT_TRUE(loaded.problem.empty());
  const auto other_size = store.load("good", 640, 480);
  EXPECT_FALSE(other_size.calibration);
  EXPECT_TRUE(other_size.set_aside_as.empty());
  EXPECT_TRUE(fs::exists(dir / "good.yaml"));

  const auto corrupt = store.load("corrupt", 1280, 960);
  EXPECT_FALSE(corrupt.calibration);
  EXPECT_EQ(corrupt.set_aside_as, (dir / "corrupt.yaml.bad.1").string()) << corrupt.problem;
  EXPECT_EQ(readText((dir / "corrupt.yaml.bad").string()), "an earlier bad file, never overwritten");
  EXPECT_FALSE(fs::exists(dir / "corrupt.yaml"));
  const auto nan = store.load("nan", 1280, 960);
  EXPECT_FALSE(nan.calibration);
  EXPECT_EQ(nan.set_aside_as, (dir / "nan.yaml.bad").string()) << nan.problem;
  const auto absent = store.load("absent", 1280, 960);
  EXPECT_FALSE(absent.calibration);
  EXPECT_TRUE(absent.problem.empty());
}

TEST(CalibrationStore, StaleTemporariesGoAndOverlaysStay)
{
  const fs::path dir = freshDir("store_temp");
  const ic::CalibrationStore store(dir.string());
  for (const char* name : {"cam.yaml.tmp.Ab3xYz", "cam_overlay.png.tmp.Q1w2E3", ".cam_overlay.tmp.png",
                           "cam_report.html.tmp.Zz9Yy8", "cam_report_coverage.png.tmp.Aa1Bb2"})
    writeText(dir / name, "");
  writeText(dir / "other.yaml.tmp.Ab3xYz", "not ours");
  writeText(dir / "cam.yaml.tmp.notes", "not a mkstemp name");
  writeText(dir / "cam_report.html", "a report");
  writeText(dir / "other_report.html.tmp.Zz9Yy8", "not ours");
  EXPECT_EQ(store.removeStaleTemporaries({"cam"}).size(), 5u);
  EXPECT_TRUE(fs::exists(dir / "other.yaml.tmp.Ab3xYz"));
  EXPECT_TRUE(fs::exists(dir / "cam.yaml.tmp.notes"));
  EXPECT_TRUE(fs::exists(dir / "cam_report.html"));
  EXPECT_TRUE(fs::exists(dir / "other_report.html.tmp.Zz9Yy8"));

  const auto calibration = ic::parseCalibration(exampleCalibrationText());
  ASSERT_TRUE(calibration);
  const cv::Mat drawn(960, 1280, CV_8UC3, cv::Scalar(10, 200, 30));
  ASSERT_TRUE(store.save("cam", *calibration, drawn));
  const std::string png = readText(store.overlayPath("cam"));
  ASSERT_FALSE(png.empty());
  // After a restart there is no image to draw on: the overlay saved before stays as it was.
  ASSERT_TRUE(store.save("cam", *calibration, cv::Mat()));
  EXPECT_EQ(readText(store.overlayPath("cam")), png);
  ic::CalibrationFile broken = *calibration;
  broken.camera.intrinsics().fx = std::nan("");
  EXPECT_FALSE(store.save("cam", broken, cv::Mat()));
  EXPECT_TRUE(ic::loadCalibrationFile(store.calibrationPath("cam")));
  EXPECT_EQ(fs::directory_iterator(dir) == fs::directory_iterator(), false);
  size_t temporaries = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    temporaries += entry.path().filename().string().find(".tmp.") != std::string::npos;
  EXPECT_EQ(temporaries, 3u);  // only the three that are not ours
}

TEST(CalibrationStore, ARecalibrationKeepsThePreviousOneBesideIt)
{
  const fs::path dir = freshDir("store_archive");
  const ic::CalibrationStore store(dir.string());
  const auto first = ic::parseCalibration(exampleCalibrationText());
  ASSERT_TRUE(first);
  std::string kept = "unset";
  ASSERT_TRUE(store.save("cam", *first, cv::Mat(960, 1280, CV_8UC3, cv::Scalar(1, 2, 3)), &kept));
  EXPECT_TRUE(kept.empty()) << "nothing to keep before the first calibration";
  // The same calibration saved again (~save), also as read back after a restart: nothing kept.
  ASSERT_TRUE(store.save("cam", *first, cv::Mat(), &kept));
  EXPECT_TRUE(kept.empty());
  const auto reloaded = store.saved("cam");
  ASSERT_TRUE(reloaded);
  ASSERT_TRUE(store.save("cam", *reloaded, cv::Mat(), &kept));
  EXPECT_TRUE(kept.empty()) << kept;
  const std::string first_text = readText(store.calibrationPath("cam"));

  ic::CalibrationFile second = *first;
  second.camera.pose().translation.x() += 0.05;
  ASSERT_TRUE(store.save("cam", second, cv::Mat(960, 1280, CV_8UC3, cv::Scalar(4, 5, 6)), &kept));
  ASSERT_FALSE(kept.empty());
  EXPECT_EQ(fs::path(kept).parent_path(), dir);
  EXPECT_EQ(fs::path(kept).filename().string().rfind("cam.20", 0), 0u) << kept;  // cam.<UTC>.yaml
  EXPECT_EQ(readText(kept), first_text);
  const auto now = store.saved("cam");
  ASSERT_TRUE(now);
  EXPECT_NEAR(now->camera.pose().translation.x(), second.camera.pose().translation.x(), 1e-9);
  size_t overlays = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    overlays += entry.path().filename().string().rfind("cam_overlay.20", 0) == 0;
  EXPECT_EQ(overlays, 1u);

  // A third calibration in the same second: a second copy, the first never overwritten.
  ic::CalibrationFile third = second;
  third.camera.pose().translation.x() += 0.05;
  std::string kept_again;
  ASSERT_TRUE(store.save("cam", third, cv::Mat(), &kept_again));
  ASSERT_FALSE(kept_again.empty());
  EXPECT_NE(kept_again, kept);
  EXPECT_EQ(readText(kept), first_text);
  EXPECT_FALSE(store.saved("absent"));
}
