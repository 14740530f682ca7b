// Reads a recorded survey bag into a Survey as calibration_node would have received it live: every transform first
// (so that each frame finds its pose whatever the order of the messages), then the Xtion's frames (RGB, depth and
// camera info matched by stamp, posed in the world frame, with odometry when the bag has it) and the fixed cameras'
// images. calibrate_survey's input stage.
#ifndef INSITU_CALIBRATION_ROS_SURVEY_BAG_READER_H
#define INSITU_CALIBRATION_ROS_SURVEY_BAG_READER_H

#include <cstddef>
#include <functional>
#include <map>
#include <string>

#include "insitu_calibration/error.h"
#include "insitu_calibration/survey/survey.h"

namespace insitu_calibration
{
struct SurveyBagOptions
{
  std::string world_frame = "map";
  std::string odom_frame = "odom";  // empty: no odometry for the map adjustment
  std::string rgb_topic = "/camera/rgb/image_raw";
  std::string depth_topic = "/camera/depth_registered/image_raw";
  std::string info_topic = "/camera/rgb/camera_info";
  std::map<std::string, std::string> camera_of_topic;  // fixed cameras' image topics -> camera names
};

struct SurveyBagReport
{
  size_t frames_without_pose = 0;  // RGB-D frames tf could not place in the world frame
};

// Errors (kInvalidInput): the path is a directory, the bag cannot be opened or read to its end (with the hint that
// `rosbag reindex` repairs a recording that was interrupted).
Expected<SurveyBagReport> readSurveyBag(const std::string& path, const SurveyBagOptions& options, Survey* survey);

// Only the Xtion's RGB-D frames, posed by tf, each to sink (a first pass over the bag: calibrate_survey
// --depth-registration auto estimates the depth's misregistration from them). Errors as readSurveyBag.
Expected<SurveyBagReport> readSurveyRgbdFrames(const std::string& path, const SurveyBagOptions& options,
                                               const std::function<void(const RgbdFrame&)>& sink);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ROS_SURVEY_BAG_READER_H
