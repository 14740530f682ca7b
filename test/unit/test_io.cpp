#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <random>

#include "insitu_calibration/io/atomic_file.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/io/correspondence_file.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

namespace ic = insitu_calibration;
namespace fs = std::filesystem;

namespace
{
fs::path tempDir()
{
  const fs::path dir = fs::temp_directory_path() / ("insitu_io_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}
}  // namespace

TEST(CorrespondenceFile, RoundTrip)
{
  std::mt19937 rng(1);
  const ic::CameraModel camera = ic::randomCamera({}, rng);
  ic::SyntheticLineOptions options;
  options.lines = 12;
  options.image_points_per_line = 4;
  ic::SyntheticLines lines = ic::makeSyntheticLines(camera, 1280, 960, options, rng);
  lines.data.camera_name = "lobby_cam";
  lines.data.points = ic::endPointCorrespondences(camera, lines.segments, 0.0, rng);
  const std::string path = (tempDir() / "c.yaml").string();
  ASSERT_TRUE(ic::saveCorrespondenceFile(path, lines.data));
  const auto loaded = ic::loadCorrespondenceFile(path);
  ASSERT_TRUE(loaded) << loaded.error().describe();
  EXPECT_EQ(loaded->camera_name, "lobby_cam");
  EXPECT_EQ(loaded->image_width, 1280);
  ASSERT_EQ(loaded->lines.size(), lines.data.lines.size());
  ASSERT_EQ(loaded->points.size(), lines.data.points.size());
  for (size_t i = 0; i < loaded->lines.size(); ++i)
  {
    ASSERT_EQ(loaded->lines[i].image.size(), 4u);
    for (size_t j = 0; j < 4; ++j)
      EXPECT_LT((loaded->lines[i].image[j] - lines.data.lines[i].image[j]).norm(), 1e-8);
    EXPECT_LT((loaded->lines[i].world[0] - lines.data.lines[i].world[0]).norm(), 1e-9);
  }
}

TEST(CorrespondenceFile, ErrorsNameTheProblem)
{
  const auto expectError = [](const std::string& text, const std::string& fragment) {
    const auto r = ic::parseCorrespondences(text);
    ASSERT_FALSE(r) << text;
    EXPECT_NE(r.error().message().find(fragment), std::string::npos) << r.error().message();
  };
  expectError("image_width: 640\nlines: []\n", "image_height");
  expectError("image_width: 640\nimage_height: 480\n", "lines");
  expectError("image_width: 640\nimage_height: 480\nlines:\n  - image: [[1, 2]]\n    world: [[0, 0, 1]]\n",
              "at least 2");
  expectError("image_width: 640\nimage_height: 480\nlines:\n  - image: [[1, 2], [3]]\n    world: [[0, 0, 1]]\n",
              "lines[0].image[1]");
  expectError("image_width: 640\nimage_height: 480\nlines:\n  - image: [[1, 2], [3, x]]\n    world: [[0, 0, 1]]\n",
              "not a number");
  expectError("image_width: 640\nimage_height: 480\nlines:\n  - image: [[1, 2], [3, .nan]]\n    world: [[0, 0, 1]]\n",
              "NaN");
  expectError("image_width: [640\n", "not valid YAML");
  const auto missing = ic::loadCorrespondenceFile("/nonexistent/file.yaml");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code(), ic::ErrorCode::kIoError);
}

TEST(CalibrationFile, RoundTripKeepsTheCamera)
{
  std::mt19937 rng(2);
  ic::CalibrationFile file;
  file.camera_name = "lobby_cam";
  file.image_width = 1280;
  file.image_height = 960;
  file.camera = ic::randomCamera({}, rng);
  ic::CalibrationQuality q;
  q.rms_px = 0.25;
  q.lines = 30;
  q.extra["iterations"] = 4;
  file.quality = q;
  const std::string path = (tempDir() / "cal.yaml").string();
  ASSERT_TRUE(ic::saveCalibrationFile(path, file));
  const auto loaded = ic::loadCalibrationFile(path);
  ASSERT_TRUE(loaded) << loaded.error().describe();
  EXPECT_EQ(loaded->camera_name, "lobby_cam");
  const ic::CameraErrors e = ic::compareCameras(file.camera, loaded->camera);
  EXPECT_LT(std::abs(e.focal_relative), 1e-12);
  EXPECT_LT(e.rotation_rad, 1e-12);
  EXPECT_LT(e.center_m, 1e-12);
  EXPECT_LT(e.lambda_relative, 1e-12);
  ASSERT_TRUE(loaded->quality);
  EXPECT_EQ(loaded->quality->lines, 30u);
  EXPECT_DOUBLE_EQ(loaded->quality->extra.at("iterations"), 4.0);
  // camera_calibration_parsers' keys are present, with a barrel plumb_bob approximation.
  const auto text = ic::readFile(path);
  for (const char* key : {"camera_matrix:", "distortion_model: plumb_bob", "distortion_coefficients:",
                          "rectification_matrix:", "projection_matrix:", "world_projection_matrix:"})
    EXPECT_NE(text->find(key), std::string::npos) << key;
  EXPECT_LT(loaded->plumb_bob.coefficients[0], 0.0);
}

TEST(AtomicFile, FailureLeavesTheOldFileAndNoTemporary)
{
  const fs::path dir = tempDir() / "atomic";
  fs::create_directories(dir);
  const std::string path = (dir / "x.yaml").string();
  ASSERT_TRUE(ic::writeFileAtomically(path, "old\n"));
  ASSERT_TRUE(ic::writeFileAtomically(path, "new\n"));
  EXPECT_EQ(*ic::readFile(path), "new\n");
  // A target that is a directory cannot be replaced: the error is reported and nothing is left behind.
  fs::create_directories(dir / "blocked");
  const ic::Status s = ic::writeFileAtomically((dir / "blocked").string(), "x");
  EXPECT_FALSE(s);
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    files += entry.is_regular_file() ? 1 : 0;
  EXPECT_EQ(files, 1u);
}
