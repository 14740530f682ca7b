// A fixed camera's median image with no edge line at all, only thin ones (a tiled floor's joints seen from above):
// without thin_lines the refusal says what the view shows and what to do; with thin_lines its thin lines are used
// from the start (nothing else could calibrate it), instead of the refusal "no lines were found".
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/survey/fixed_camera.h"

namespace ic = insitu_calibration;

namespace
{
// Grey tiles 60 px wide with bright joints 2 px wide, slightly blurred (as a sensor shows grout from metres away).
cv::Mat tiledFloor()
{
  cv::Mat image(480, 640, CV_8UC1, cv::Scalar(70));
  for (int x = 30; x < 640; x += 60)
    cv::line(image, {x, 0}, {x + 40, 479}, cv::Scalar(150), 2, cv::LINE_AA);
  for (int y = 20; y < 480; y += 60)
    cv::line(image, {0, y}, {639, y + 30}, cv::Scalar(150), 2, cv::LINE_AA);
  cv::GaussianBlur(image, image, {0, 0}, 0.8);
  return image;
}

ic::FixedCamera cameraWith(bool thin_lines)
{
  ic::FixedCameraConfig config;
  config.name = "floor_cam";
  config.image_topic = "/floor_cam/image_raw";
  config.image_width = 640;
  config.image_height = 480;
  ic::CameraPrior prior;
  prior.position = Eigen::Vector3d(0.0, 0.0, 4.0);
  prior.direction = Eigen::Vector3d(0.3, 0.0, -1.0);
  config.prior = prior;
  ic::FixedCameraOptions options;
  options.image_lines.refiner.thin_lines = thin_lines;
  return ic::FixedCamera(config, options);
}
}  // namespace

TEST(FixedCameraLines, AViewOfJointsAloneIsToldSoOrUsesItsThinLines)
{
  const std::vector<ic::Segment3d> map = {{{1.0, -1.0, 0.0}, {1.0, 1.0, 0.0}}, {{1.5, -1.0, 0.0}, {1.5, 1.0, 0.0}}};
  ic::FixedCamera plain = cameraWith(false);
  ASSERT_TRUE(plain.addImage(tiledFloor()));
  const auto refused = plain.calibrate(map, "map");
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code(), ic::ErrorCode::kNotEnoughData);
  const std::string message = refused.error().message();
  std::printf("%s\n", message.c_str());
  EXPECT_NE(message.find("no lines were found in the median image"), std::string::npos);
  EXPECT_NE(message.find("thin lines without a step across them"), std::string::npos);
  EXPECT_NE(message.find("calibrate_lines"), std::string::npos);

  ic::FixedCamera thin = cameraWith(true);
  ASSERT_TRUE(thin.addImage(tiledFloor()));
  const auto tried = thin.calibrate(map, "map");  // two map lines cannot calibrate it: refused, but not for lines
  ASSERT_FALSE(tried);
  std::printf("%s\n", tried.error().message().c_str());
  EXPECT_EQ(tried.error().message().find("no lines were found"), std::string::npos);
}
