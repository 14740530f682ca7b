// Records a simulated survey (simulation/survey.h) into a rosbag that looks like a real one: openni2_launch's topics
// and frames for the Xtion, network-camera topics for the fixed cameras, /tf and /tf_static. LZ4-compressed, written
// to "<path>.active" and renamed when complete (as rosbag record does).
#ifndef INSITU_CALIBRATION_ROS_SURVEY_BAG_WRITER_H
#define INSITU_CALIBRATION_ROS_SURVEY_BAG_WRITER_H

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <sensor_msgs/CameraInfo.h>

#include "insitu_calibration/error.h"
#include "insitu_calibration/simulation/survey.h"

namespace insitu_calibration
{
// Topic names.
extern const char* const kXtionRgbImageTopic;              // /camera/rgb/image_raw
extern const char* const kXtionRgbInfoTopic;               // /camera/rgb/camera_info
extern const char* const kXtionDepthImageTopic;            // /camera/depth_registered/image_raw
extern const char* const kXtionDepthInfoTopic;             // /camera/depth_registered/camera_info
extern const char* const kXtionOpticalFrame;               // camera_rgb_optical_frame
std::string fixedImageTopic(const std::string& camera);    // /fixed/<camera>/image_raw
std::string fixedInfoTopic(const std::string& camera);     // /fixed/<camera>/camera_info
std::string fixedOpticalFrame(const std::string& camera);  // <camera>_optical_frame

// Every topic of a survey bag of this world, sorted.
std::vector<std::string> surveyTopics(const simulation::World& world);

// openni2's CameraInfo of the Xtion (plumb_bob with zero coefficients, K, R = I, P = [K | 0]).
sensor_msgs::CameraInfo xtionCameraInfo(const simulation::XtionConfig& xtion);
// An uncalibrated network camera's CameraInfo: the nominal size only.
sensor_msgs::CameraInfo nominalCameraInfo(int width, int height);

struct SurveyBagSummary
{
  size_t messages = 0;
  uint64_t bytes = 0;        // size of the bag file
  double total_s = 0.0;      // wall time of the whole recording
  double bag_write_s = 0.0;  // message conversion, compression and writing
};

// progress(done, total) is called after every RGB-D frame.
Expected<SurveyBagSummary> writeSurveyBag(const simulation::SurveySimulator& survey, const std::string& path,
                                          const std::function<void(size_t, size_t)>& progress = {});

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ROS_SURVEY_BAG_WRITER_H
