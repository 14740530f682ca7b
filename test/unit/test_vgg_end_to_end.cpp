// Real data: every view of the Oxford VGG Model House and Merton College I scenes is converted to a correspondence
// file and calibrated by the calibrate_lines executable, end to end; the camera it writes is compared with the
// view's ground-truth P.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/io/correspondence_file.h"
#include "insitu_calibration/io/vgg_dataset.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/solvers/decomposition.h"

namespace ic = insitu_calibration;
namespace fs = std::filesystem;

namespace
{
double median(std::vector<double> v)
{
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

int run(const std::string& command)
{
  const int status = std::system((command + " > /dev/null").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

void checkScene(const std::string& scene, int width, int height)
{
  const fs::path scene_dir = fs::path(INSITU_VGG_DIR) / scene;
  ASSERT_TRUE(fs::is_directory(scene_dir)) << scene_dir << " is missing: the VGG data lives in ../shared/data/vgg "
                                           << "beside the repository (set -DINSITU_VGG_DIR=... to point elsewhere)";
  const fs::path out = fs::temp_directory_path() / ("insitu_vgg_" + std::to_string(::getpid())) / scene;
  fs::create_directories(out);
  const std::string tools = INSITU_TOOL_DIR;
  ASSERT_EQ(run(tools + "/vgg_to_correspondences '" + scene_dir.string() + "' --width " + std::to_string(width) +
                " --height " + std::to_string(height) + " --out-dir '" + out.string() + "'"),
            0);

  const auto views = ic::loadVggScene(scene_dir.string(), width, height);
  ASSERT_TRUE(views) << views.error().describe();
  std::vector<double> focal, rotation_deg, center_fraction, median_px;
  for (const auto& view : *views)
  {
    const std::string input = (out / (view.name + ".yaml")).string();
    const std::string result_path = (out / (view.name + "_result.yaml")).string();
    ASSERT_EQ(run(tools + "/calibrate_lines '" + input + "' --output '" + result_path + "'"), 0) << view.name;
    const auto result = ic::loadCalibrationFile(result_path);
    ASSERT_TRUE(result) << result.error().describe();
    const auto truth = ic::decomposeProjection(view.projection);
    ASSERT_TRUE(truth);
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    size_t n = 0;
    for (const auto& line : view.data.lines)
      for (const auto& x : line.world)
      {
        centroid += x;
        ++n;
      }
    const double viewing_distance = (centroid / n - truth->pose.center()).norm();
    focal.push_back(std::abs(ic::relativeFocalError(truth->intrinsics, result->camera.intrinsics())));
    rotation_deg.push_back(ic::rotationDistance(truth->pose.rotation, result->camera.pose().rotation) * 180.0 / M_PI);
    center_fraction.push_back(ic::centerDistance(truth->pose, result->camera.pose()) / viewing_distance);
    ASSERT_TRUE(result->quality);
    median_px.push_back(result->quality->median_px);
    std::printf("%s %-12s %3zu lines  focal %.3f %%  rotation %.3f deg  centre %.3f %% of %.2f  median %.3f px\n",
                scene.c_str(), view.name.c_str(), view.data.lines.size(), 100 * focal.back(), rotation_deg.back(),
                100 * center_fraction.back(), viewing_distance, median_px.back());
  }
  EXPECT_LT(median(focal), 0.01) << scene;
  EXPECT_LT(median(rotation_deg), 0.5) << scene;
  EXPECT_LT(median(center_fraction), 0.01) << scene;
  EXPECT_LT(median(median_px), 0.5) << scene;
  std::printf(
      "%s medians: focal %.3f %%, rotation %.3f deg, centre %.3f %% of the viewing distance, "
      "point-to-line %.3f px\n",
      scene.c_str(), 100 * median(focal), median(rotation_deg), 100 * median(center_fraction), median(median_px));
}
}  // namespace

TEST(VggEndToEnd, ModelHouse)
{
  checkScene("Model-House", 768, 576);
}

TEST(VggEndToEnd, MertonCollege)
{
  checkScene("Merton-College-I", 1024, 768);
}
