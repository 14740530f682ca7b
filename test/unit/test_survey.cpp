#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/survey/keyframe_selector.h"
#include "insitu_calibration/survey/temporal_median.h"

namespace ic = insitu_calibration;

TEST(KeyframeSelector, KeepsFramesThatMovedOrTurned)
{
  ic::KeyframeSelector selector({0.1, 5.0, 0.0});
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  EXPECT_TRUE(selector.accept(pose, 0.0));  // the first frame
  pose.translation().x() = 0.05;
  EXPECT_FALSE(selector.accept(pose, 0.2));  // 5 cm: not enough
  pose.translation().x() = 0.11;
  EXPECT_TRUE(selector.accept(pose, 0.4));
  pose.linear() = Eigen::AngleAxisd(4.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_FALSE(selector.accept(pose, 0.6));
  pose.linear() = Eigen::AngleAxisd(6.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(selector.accept(pose, 0.8));
  EXPECT_TRUE(selector.accept(pose, 0.1));  // the clock went back (a bag restarted): start over
}

TEST(TemporalMedian, RemovesATransientPerson)
{
  ic::TemporalMedian median(9);
  cv::Mat background(120, 160, CV_8UC1, cv::Scalar(40));
  cv::rectangle(background, cv::Rect(40, 30, 60, 50), cv::Scalar(200), cv::FILLED);
  for (int k = 0; k < 9; ++k)
  {
    cv::Mat frame = background.clone();
    if (k < 4)  // someone walks through in 4 of 9 frames
      cv::rectangle(frame, cv::Rect(10 + 20 * k, 20, 25, 80), cv::Scalar(120), cv::FILLED);
    ASSERT_TRUE(median.add(frame));
  }
  cv::Mat diff;
  cv::absdiff(median.median(), background, diff);
  EXPECT_EQ(cv::countNonZero(diff), 0);
}

TEST(TemporalMedian, RefusesEmptyAndMismatchedImages)
{
  ic::TemporalMedian median(3);
  EXPECT_FALSE(median.add(cv::Mat()));
  ASSERT_TRUE(median.add(cv::Mat(10, 10, CV_8UC3, cv::Scalar(1, 2, 3))));
  const ic::Status s = median.add(cv::Mat(11, 10, CV_8UC1));
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message().find("differs"), std::string::npos);
  EXPECT_EQ(median.size(), 1u);
  EXPECT_TRUE(ic::TemporalMedian().median().empty());
}

// The median is cached for a set of images and shared by copies (the node's snapshots): each copy must still get
// the median of its own images, also when copies diverge or the buffer slides, and writing on a returned median
// must not change the next one.
TEST(TemporalMedian, CopiesShareTheCacheButEachGetsItsOwnImagesMedian)
{
  const auto plain = [](int value) { return cv::Mat(8, 8, CV_8UC1, cv::Scalar(value)); };
  const auto valueOf = [](const cv::Mat& m) { return static_cast<int>(m.at<uint8_t>(4, 4)); };
  ic::TemporalMedian live(3);
  for (int v : {10, 20, 30})
    ASSERT_TRUE(live.add(plain(v)));
  cv::Mat first = live.median();
  EXPECT_EQ(valueOf(first), 20);
  first.setTo(cv::Scalar(255));  // the caller draws on its copy
  EXPECT_EQ(valueOf(live.median()), 20);

  ic::TemporalMedian snapshot = live;  // shares the cache
  EXPECT_EQ(valueOf(snapshot.median()), 20);
  ASSERT_TRUE(live.add(plain(40)));  // slides: 20, 30, 40
  EXPECT_EQ(valueOf(live.median()), 30);
  EXPECT_EQ(valueOf(snapshot.median()), 20);  // still its own images: 10, 20, 30
  ASSERT_TRUE(snapshot.add(plain(0)));        // diverges: 20, 30, 0
  EXPECT_EQ(valueOf(snapshot.median()), 20);
  EXPECT_EQ(valueOf(live.median()), 30);
  live.clear();
  EXPECT_TRUE(live.median().empty());
  ASSERT_TRUE(live.add(plain(7)));
  EXPECT_EQ(valueOf(live.median()), 7);
}
