// calibration_node under hostile topics (calibration_hostile.test, issue 16): images with a wrong encoding, step or
// size, 1x1 images, depth in the wrong encoding, camera_info of zeros, NaN and infinite transforms, then a flood of
// 10^4 garbage images. The node must keep answering ~status and its memory must stay flat.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>

#include "insitu_calibration/CalibrationStatus.h"
#include "node_process.h"

namespace ic = insitu_calibration;

namespace
{
sensor_msgs::Image image(const std::string& encoding, uint32_t width, uint32_t height, uint32_t step, size_t bytes,
                         const ros::Time& stamp, const std::string& frame)
{
  sensor_msgs::Image m;
  m.header.stamp = stamp;
  m.header.frame_id = frame;
  m.encoding = encoding;
  m.width = width;
  m.height = height;
  m.step = step;
  m.data.assign(bytes, 77);
  return m;
}

// ~status answers within a few seconds: the node is alive and not blocked.
bool answers()
{
  ic::CalibrationStatus status;
  const auto start = std::chrono::steady_clock::now();
  const bool called = ros::service::call("/hostile_node/status", status);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return called && status.response.cameras.size() == 4 && seconds < 5.0;
}

// Every malformed fixed-camera image and RGB-D triple of the issue, once.
void publishHostileSet(ros::Publisher& fixed, ros::Publisher& rgb, ros::Publisher& depth, ros::Publisher& info,
                       ros::Publisher& tf)
{
  const ros::Time now = ros::Time::now();
  const std::string optical = "fixed_optical";
  fixed.publish(image("bogus", 1280, 960, 3840, 3840 * 960, now, optical));  // unknown encoding
  fixed.publish(image("rgb8", 1280, 960, 100, 100 * 960, now, optical));     // step below the width
  fixed.publish(image("rgb8", 1280, 960, 3840, 1000, now, optical));         // data shorter than claimed
  fixed.publish(image("rgb8", 1, 1, 3, 3, now, optical));                    // 1x1
  fixed.publish(image("rgb8", 0, 0, 0, 0, now, optical));                    // empty
  fixed.publish(image("rgb8", 100000, 100000, 300000, 16, now, optical));    // a huge claimed size
  fixed.publish(image("rgb8", 640, 480, 1920, 1920 * 480, now, optical));    // not the configured size
  fixed.publish(image("16UC1", 1280, 960, 2560, 2560 * 960, now, optical));  // depth on a colour camera
  const std::string frame = "camera_rgb_optical_frame";
  rgb.publish(image("rgb8", 1, 1, 3, 3, now, frame));
  depth.publish(image("rgb8", 1, 1, 3, 3, now, frame));  // depth in a colour encoding
  sensor_msgs::CameraInfo zeros;                         // K, D, P all zeros
  zeros.header.stamp = now;
  zeros.header.frame_id = frame;
  zeros.width = 1;
  zeros.height = 1;
  info.publish(zeros);
  tf2_msgs::TFMessage transforms;
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()})
  {
    geometry_msgs::TransformStamped t;
    t.header.stamp = now;
    t.header.frame_id = "map";
    t.child_frame_id = "base_link";
    t.transform.translation.x = bad;
    t.transform.rotation.w = bad;
    transforms.transforms.push_back(t);
  }
  tf.publish(transforms);
}
}  // namespace

TEST(CalibrationNodeHostileTopics, KeepsAnsweringWithFlatMemory)
{
  NodeProcess node("hostile_node");
  ASSERT_TRUE(node.started());
  ASSERT_TRUE(ros::service::waitForService("/hostile_node/status", ros::Duration(60.0)));
  ros::NodeHandle nh;
  ros::Publisher fixed = nh.advertise<sensor_msgs::Image>("/fixed/good_cam/image_raw", 100);
  ros::Publisher rgb = nh.advertise<sensor_msgs::Image>("/camera/rgb/image_raw", 100);
  ros::Publisher depth = nh.advertise<sensor_msgs::Image>("/camera/depth_registered/image_raw", 100);
  ros::Publisher info = nh.advertise<sensor_msgs::CameraInfo>("/camera/rgb/camera_info", 100);
  ros::Publisher tf = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
  // A valid pose of the Xtion, so that the malformed RGB-D triples reach the node's conversion (not only tf).
  ros::Publisher tf_static = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  tf2_msgs::TFMessage pose;
  pose.transforms.resize(1);
  pose.transforms[0].header.frame_id = "map";
  pose.transforms[0].child_frame_id = "camera_rgb_optical_frame";
  pose.transforms[0].transform.rotation.w = 1.0;
  tf_static.publish(pose);
  // Until the node is connected to every topic.
  for (int i = 0; i < 100 && (fixed.getNumSubscribers() == 0 || rgb.getNumSubscribers() == 0 ||
                              depth.getNumSubscribers() == 0 || info.getNumSubscribers() == 0);
       ++i)
    ros::Duration(0.1).sleep();
  ASSERT_GT(fixed.getNumSubscribers(), 0u);

  for (int round = 0; round < 5; ++round)
  {
    publishHostileSet(fixed, rgb, depth, info, tf);
    ros::Duration(0.2).sleep();
    ASSERT_TRUE(answers()) << "round " << round;
  }

  // The flood: 10^4 garbage images (1000 first, to let the node's buffers reach their steady size).
  const auto flood = [&](int count) {
    for (int i = 0; i < count; ++i)
    {
      fixed.publish(image(i % 2 ? "bogus" : "rgb8", 1280, 960, 3840, 4096, ros::Time::now(), "fixed_optical"));
      if (i % 100 == 0)
        ros::Duration(0.01).sleep();
    }
    ros::Duration(2.0).sleep();
  };
  flood(1000);
  const long before_kb = node.residentKb();
  flood(10000);
  const long after_kb = node.residentKb();
  ASSERT_TRUE(answers());
  std::printf("node memory: %ld kB after 1000 garbage images, %ld kB after 10^4 more\n", before_kb, after_kb);
  ASSERT_GT(before_kb, 0);
  EXPECT_LT(after_kb - before_kb, 20 * 1024) << "the node's memory grew by more than 20 MB";
  EXPECT_EQ(node.stop(), 0) << "the node did not shut down cleanly";
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_calibration_hostile");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
