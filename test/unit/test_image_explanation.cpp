// The final check of a fixed camera's calibration (image_explanation.h): the true camera of a simulated view explains
// its image (its map lines lie on the image's edges), deliberately wrong cameras do not and are refused.
#include <gtest/gtest.h>

#include <string>

#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/survey/fixed_camera.h"
#include "insitu_calibration/survey/image_explanation.h"
#include "insitu_calibration/test_support/edges_in_view.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const std::string kWorld = std::string(INSITU_SOURCE_DIR) + "/config/worlds/waiting_room.yaml";

ic::CameraModel moved(ic::CameraModel c, const Eigen::Vector3d& shift_world)
{
  ic::CameraPose& pose = c.pose();
  pose.translation -= pose.rotation * shift_world;  // centre + shift
  return c;
}
}  // namespace

TEST(ImageExplanation, TrueCameraAcceptedWrongCamerasRefused)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world) << world.error().describe();
  const sim::Renderer renderer(*world);
  const ic::ImageExplanationOptions options = ic::FixedCameraOptions{}.explanation;
  for (const auto& cam : world->fixed_cameras)
  {
    const auto view = renderer.render(sim::ViewCamera::fromModel(cam.camera, cam.width, cam.height));
    const auto map = ic::edgesSeenInView(*world, cam.camera, view);
    const auto truth = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, options);
    std::printf("%s true camera: %s\n", cam.name.c_str(), truth.describe().c_str());
    EXPECT_TRUE(ic::acceptExplanation(truth, options)) << cam.name;
    EXPECT_GT(truth.map_lines, 20u);

    std::vector<std::pair<std::string, ic::CameraModel>> wrong;
    ic::CameraModel focal = cam.camera;
    focal.intrinsics().fx *= 1.06;
    focal.intrinsics().fy *= 1.06;
    wrong.emplace_back("focal +6 %", focal);
    wrong.emplace_back("moved 0.15 m sideways",
                       moved(cam.camera, 0.15 * cam.camera.pose().rotation.row(0).transpose()));
    wrong.emplace_back("moved one floor tile (0.5 m) along x", moved(cam.camera, Eigen::Vector3d(0.5, 0, 0)));
    ic::CameraModel turned = cam.camera;
    turned.pose().rotation =
        Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * turned.pose().rotation;
    turned.pose().translation = Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                                cam.camera.pose().translation;
    wrong.emplace_back("rolled 2 deg about its axis", turned);
    for (const auto& [what, camera] : wrong)
    {
      const auto e = ic::explainImage(view.rgb, camera, cam.width, cam.height, map, nullptr, options);
      const ic::Status accepted = ic::acceptExplanation(e, options);
      std::printf("%s %s: %s\n", cam.name.c_str(), what.c_str(), e.describe().c_str());
      EXPECT_FALSE(accepted) << cam.name << " " << what;
      if (!accepted)
      {
        EXPECT_NE(accepted.error().message().find("does not explain the image"), std::string::npos);
      }
    }
  }
}
