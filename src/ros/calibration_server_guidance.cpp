// The calibration node's survey guidance after a refusal: the core's (survey/survey_guidance.h) computed on the
// refused copy of the camera, its text appended to the refusal, its picture saved beside the overlay
// (<camera>_survey_hint.png) and published on the latched ~<camera>/survey_hint, and its floor regions as
// translucent markers (namespace survey_hint) on ~markers.
#include <cv_bridge/cv_bridge.h>

#include "insitu_calibration/io/calibration_store.h"
#include "insitu_calibration/ros/calibration_server.h"
#include "insitu_calibration/ros/conversions.h"
#include "insitu_calibration/survey/survey_hint_file.h"

namespace insitu_calibration
{
namespace
{
constexpr int kMaxHintRegions = 10;  // marker ids per camera: a polygon and an arrow per region

visualization_msgs::Marker hintMarker(const std::string& frame, int id, int type)
{
  visualization_msgs::Marker m;
  m.header.frame_id = frame;
  m.ns = "survey_hint";
  m.id = id;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = m.scale.y = m.scale.z = 1.0;
  m.color.r = 1.0f;
  m.color.g = 0.55f;
  m.color.b = 0.0f;
  m.color.a = 0.35f;
  return m;
}
}  // namespace

std::string CalibrationServer::publishSurveyGuidance(const std::string& name, const FixedCamera& camera,
                                                     const std::vector<Segment3d>& map, const Error& error)
{
  ImageLineOptions image_lines;
  SurveyGuidanceOptions options;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    image_lines = survey_->options().cameras.image_lines;
    options = surveyGuidanceOptions(survey_->keyframes(), survey_->options().floor.floor_height_m,
                                    survey_->options().map.max_sigma_m);
  }
  options.max_regions = std::min<size_t>(options.max_regions, kMaxHintRegions);
  const auto guidance = guideSurvey(camera, map, image_lines, options);
  if (!guidance)
  {
    ROS_WARN_STREAM("calibration_node: " << name << ": no survey guidance: " << guidance.error().message());
    return error.describe();
  }
  const cv::Mat hint = drawSurveyHint(camera.medianImage(), *guidance);
  const CalibrationStore store(output_directory_);
  if (const Status saved = store.saveSurveyHint(name, hint); !saved)
    ROS_ERROR_STREAM("calibration_node: " << name << ": " << saved.error().message());
  if (const Status saved = store.saveSurveyHintYaml(name, surveyHintYaml(surveyHintOf(name, *guidance))); !saved)
    ROS_ERROR_STREAM("calibration_node: " << name << ": " << saved.error().message());
  std_msgs::Header header;
  header.stamp = ros::Time::now();
  header.frame_id = cameras_.at(name).optical_frame;
  cameras_.at(name).survey_hint_publisher.publish(cv_bridge::CvImage(header, "bgr8", hint).toImageMsg());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    survey_guidance_[name] = *guidance;
    publishMarkers();
  }
  return describeRefusal(error, *guidance);
}

void CalibrationServer::forgetSurveyGuidance(const std::string& name)
{
  std::lock_guard<std::mutex> lock(mutex_);
  survey_guidance_.erase(name);
}

void CalibrationServer::addSurveyHintMarkers(const std::string& name, int camera_id,
                                             visualization_msgs::MarkerArray* markers) const
{
  const auto found = survey_guidance_.find(name);
  const size_t regions = found == survey_guidance_.end() ? 0 : found->second.regions.size();
  for (int k = 0; k < kMaxHintRegions; ++k)
  {
    const int base = camera_id * 2 * kMaxHintRegions;
    visualization_msgs::Marker floor = hintMarker(world_frame_, base + k, visualization_msgs::Marker::TRIANGLE_LIST);
    visualization_msgs::Marker arrow =
        hintMarker(world_frame_, base + kMaxHintRegions + k, visualization_msgs::Marker::ARROW);
    if (static_cast<size_t>(k) < regions)
    {
      const UnmappedRegion& region = found->second.regions[k];
      for (const Eigen::Vector3d& p : floorTriangles(region))
        floor.points.push_back(toPointMsg(p));
      // Where the robot should stand, pointing where it should look (0.8 m long, 0.3 m above the floor).
      const Eigen::Vector3d from(region.robot_position.x(), region.robot_position.y(), 0.3);
      const Eigen::Vector3d to = from + 0.8 * Eigen::Vector3d(region.look_direction.x(), region.look_direction.y(), 0);
      arrow.points = {toPointMsg(from), toPointMsg(to)};
      arrow.scale.x = 0.08;
      arrow.scale.y = 0.16;
      arrow.scale.z = 0.2;
      arrow.color.a = 0.9f;
    }
    if (floor.points.empty())
      floor.action = arrow.action = visualization_msgs::Marker::DELETE;
    markers->markers.push_back(floor);
    markers->markers.push_back(arrow);
  }
}

}  // namespace insitu_calibration
