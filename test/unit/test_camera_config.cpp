#include <gtest/gtest.h>

#include <string>

#include "insitu_calibration/survey/camera_config.h"

namespace ic = insitu_calibration;

TEST(CameraConfig, LoadsTheShippedConfiguration)
{
  const auto config = ic::loadCameraConfig(std::string(INSITU_SOURCE_DIR) + "/config/cameras.yaml");
  ASSERT_TRUE(config) << config.error().describe();
  ASSERT_EQ(config->size(), 3u);
  for (const auto& entry : *config)
  {
    EXPECT_TRUE(entry.camera.prior.has_value()) << entry.camera.name;
    EXPECT_EQ(entry.calibrated_info_topic, "/fixed/" + entry.camera.name + "/camera_info_calibrated");
  }
}

TEST(CameraConfig, DefaultsTheTopicsFromTheName)
{
  const auto config = ic::parseCameraConfig(
      "cameras:\n  - {name: lobby_cam, image_width: 640, image_height: 480,\n"
      "     correspondence_file: /tmp/lobby.yaml}\n");
  ASSERT_TRUE(config) << config.error().describe();
  ASSERT_EQ(config->size(), 1u);
  EXPECT_EQ((*config)[0].camera.image_topic, "/fixed/lobby_cam/image_raw");
  EXPECT_EQ((*config)[0].calibrated_info_topic, "/fixed/lobby_cam/camera_info_calibrated");
}

TEST(CameraConfig, RejectsTwoCamerasPublishingOnOneTopic)
{
  // Two cameras on one image stream (the hand-picked workflow next to the automatic one) share the default
  // CameraInfo topic: refused with both names, accepted once one of them names its own topic.
  const std::string shared =
      "cameras:\n"
      "  - {name: a, image_topic: /fixed/a/image_raw, image_width: 640, image_height: 480,\n"
      "     correspondence_file: /tmp/a.yaml}\n"
      "  - {name: b, image_topic: /fixed/a/image_raw, image_width: 640, image_height: 480,\n"
      "     correspondence_file: /tmp/b.yaml";
  const auto clash = ic::parseCameraConfig(shared + "}\n");
  ASSERT_FALSE(clash);
  EXPECT_NE(clash.error().message().find("'a' and 'b'"), std::string::npos) << clash.error().message();
  EXPECT_NE(clash.error().message().find("calibrated_info_topic"), std::string::npos);

  const auto separate = ic::parseCameraConfig(shared + ", calibrated_info_topic: /fixed/b/camera_info_calibrated}\n");
  ASSERT_TRUE(separate) << separate.error().describe();
  EXPECT_EQ((*separate)[1].calibrated_info_topic, "/fixed/b/camera_info_calibrated");
}

TEST(CameraConfig, ErrorsNameTheEntryAndTheKey)
{
  const auto duplicate = ic::parseCameraConfig(
      "cameras:\n  - {name: a, image_width: 640, image_height: 480,"
      " correspondence_file: x}\n  - {name: a, image_width: 640,"
      " image_height: 480, correspondence_file: y}\n");
  ASSERT_FALSE(duplicate);
  EXPECT_NE(duplicate.error().message().find("used twice"), std::string::npos) << duplicate.error().message();

  const auto no_width = ic::parseCameraConfig("cameras:\n  - {name: a, image_height: 480, correspondence_file: x}\n");
  ASSERT_FALSE(no_width);
  EXPECT_NE(no_width.error().message().find("cameras[0].image_width"), std::string::npos) << no_width.error().message();

  const auto bad_prior = ic::parseCameraConfig(
      "cameras:\n  - {name: a, image_width: 640, image_height: 480,\n"
      "     prior: {position: [0, 0, 2], direction: [0, 0, 0],"
      " horizontal_fov_deg: 60}}\n");
  ASSERT_FALSE(bad_prior);
  EXPECT_NE(bad_prior.error().message().find("cameras[0].prior"), std::string::npos) << bad_prior.error().message();
}

TEST(CameraConfig, APriorMayKnowThePrincipalPoint)
{
  const std::string head =
      "cameras:\n  - {name: a, image_width: 640, image_height: 480,\n"
      "     prior: {position: [0, 0, 2], direction: [1, 0, 0], horizontal_fov_deg: 40";
  const auto unknown = ic::parseCameraConfig(head + "}}\n");
  ASSERT_TRUE(unknown) << unknown.error().describe();
  EXPECT_FALSE((*unknown)[0].camera.prior->principal_point.has_value());

  const auto known = ic::parseCameraConfig(head + ", principal_point: [331.5, 228.0], principal_point_sigma_px: 2}}\n");
  ASSERT_TRUE(known) << known.error().describe();
  const ic::CameraPrior& prior = *(*known)[0].camera.prior;
  ASSERT_TRUE(prior.principal_point.has_value());
  EXPECT_DOUBLE_EQ(prior.principal_point->x(), 331.5);
  EXPECT_DOUBLE_EQ(prior.principal_point->y(), 228.0);
  EXPECT_DOUBLE_EQ(prior.principal_point_sigma_px, 2.0);
  const ic::CameraModel from_prior = ic::cameraFromPrior(prior, 640, 480);
  EXPECT_DOUBLE_EQ(from_prior.intrinsics().cx, 331.5);

  const auto outside = ic::parseCameraConfig(head + ", principal_point: [700, 228]}}\n");
  ASSERT_FALSE(outside);
  EXPECT_NE(outside.error().message().find("principal_point lies outside the 640x480 image"), std::string::npos)
      << outside.error().message();
  const auto zero_sigma =
      ic::parseCameraConfig(head + ", principal_point: [320, 240], principal_point_sigma_px: 0}}\n");
  ASSERT_FALSE(zero_sigma);
  EXPECT_NE(zero_sigma.error().message().find("cameras[0].prior.principal_point_sigma_px"), std::string::npos)
      << zero_sigma.error().message();
  const auto one_number = ic::parseCameraConfig(head + ", principal_point: [320]}}\n");
  ASSERT_FALSE(one_number);
  EXPECT_NE(one_number.error().message().find("cameras[0].prior.principal_point"), std::string::npos)
      << one_number.error().message();
}
