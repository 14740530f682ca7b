#include "insitu_calibration/ros/survey_bag_reader.h"

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include "insitu_calibration/ros/conversions.h"

namespace insitu_calibration
{
namespace
{
const char* kReindexHint =
    " (a recording that was interrupted leaves the bag without its index: `rosbag reindex BAG` repairs it)";

// Opens a bag for reading; an empty string, or what is wrong with a hint at the usual cause.
std::string openBag(rosbag::Bag& bag, const std::string& path)
{
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    return path + " is a directory; give a bag file";
  try
  {
    bag.open(path, rosbag::bagmode::Read);
  }
  catch (const rosbag::BagUnindexedException& e)
  {
    return "cannot open " + path + ": " + e.what() + kReindexHint;
  }
  catch (const rosbag::BagException& e)
  {
    // A file that is there but cannot be read as a bag was most often cut short.
    const bool present = std::filesystem::is_regular_file(path, ec) && std::filesystem::file_size(path, ec) > 0;
    return "cannot open " + path + ": " + e.what() + (present ? kReindexHint : "");
  }
  return {};
}

// Every transform of the bag, kept for its whole span.
std::unique_ptr<tf2::BufferCore> readTransforms(rosbag::Bag& bag)
{
  rosbag::View all(bag);
  const ros::Duration span = all.getEndTime() - all.getBeginTime();
  auto tf = std::make_unique<tf2::BufferCore>(span + ros::Duration(10.0));
  for (const auto& m : rosbag::View(bag, rosbag::TopicQuery(std::vector<std::string>{"/tf", "/tf_static"})))
  {
    const auto msg = m.instantiate<tf2_msgs::TFMessage>();
    if (!msg)
      continue;
    const bool is_static = m.getTopic() == "/tf_static";
    for (const auto& t : msg->transforms)
      tf->setTransform(t, "bag", is_static);
  }
  return tf;
}

// The camera in the odometry frame at stamp, when tf has it (empty frame name: odometry not used).
std::optional<Eigen::Isometry3d> odometryPose(const tf2::BufferCore& tf, const std::string& odom_frame,
                                              const std::string& camera_frame, const ros::Time& stamp)
{
  if (odom_frame.empty())
    return std::nullopt;
  try
  {
    return toEigen(tf.lookupTransform(odom_frame, camera_frame, stamp).transform);
  }
  catch (const tf2::TransformException&)
  {
    return std::nullopt;
  }
}

// Where an assembled RGB-D frame goes: the frame and its odometry pose, when there is one.
using RgbdFrameSink = std::function<void(const RgbdFrame&, const std::optional<Eigen::Isometry3d>&)>;

// The Xtion's RGB, depth and camera info, matched by stamp; each complete frame goes to the sink, posed by tf.
class RgbdFrameAssembler
{
public:
  RgbdFrameAssembler(const tf2::BufferCore& tf, const SurveyBagOptions& options, RgbdFrameSink sink)
      : tf_(tf), options_(options), sink_(std::move(sink))
  {}

  void addRgb(const sensor_msgs::ImageConstPtr& image) { offer(image->header.stamp, &rgbs_, image); }
  void addDepth(const sensor_msgs::ImageConstPtr& image) { offer(image->header.stamp, &depths_, image); }
  void addInfo(const sensor_msgs::CameraInfoConstPtr& info) { offer(info->header.stamp, &infos_, info); }
  size_t framesWithoutPose() const { return no_pose_; }

private:
  template <typename Map, typename Message>
  void offer(const ros::Time& stamp, Map* waiting, const Message& message)
  {
    (*waiting)[stamp] = message;
    if (rgbs_.count(stamp) && depths_.count(stamp) && infos_.count(stamp))
      complete(stamp);
  }

  void complete(const ros::Time& stamp)
  {
    const auto rgb = rgbs_[stamp];
    rgbs_.erase(stamp);
    geometry_msgs::TransformStamped pose;
    try
    {
      pose = tf_.lookupTransform(options_.world_frame, rgb->header.frame_id, stamp);
    }
    catch (const tf2::TransformException&)
    {
      ++no_pose_;
      return;
    }
    const auto frame = toRgbdFrame(*rgb, *depths_[stamp], *infos_[stamp], toEigen(pose.transform));
    if (frame)
      sink_(*frame, odometryPose(tf_, options_.odom_frame, rgb->header.frame_id, stamp));
    depths_.erase(stamp);
    infos_.erase(stamp);
  }

  const tf2::BufferCore& tf_;
  const SurveyBagOptions& options_;
  RgbdFrameSink sink_;
  std::map<ros::Time, sensor_msgs::ImageConstPtr> rgbs_;
  std::map<ros::Time, sensor_msgs::ImageConstPtr> depths_;
  std::map<ros::Time, sensor_msgs::CameraInfoConstPtr> infos_;
  size_t no_pose_ = 0;
};

// The Xtion's frames (to the sink) and the fixed cameras' images (to the survey, when there is one), in the bag's
// order.
size_t readImages(rosbag::Bag& bag, const tf2::BufferCore& tf, const SurveyBagOptions& options, RgbdFrameSink sink,
                  Survey* survey)
{
  std::vector<std::string> topics = {options.rgb_topic, options.depth_topic, options.info_topic};
  if (survey)
    for (const auto& [topic, name] : options.camera_of_topic)
      topics.push_back(topic);
  RgbdFrameAssembler frames(tf, options, std::move(sink));
  for (const auto& m : rosbag::View(bag, rosbag::TopicQuery(topics)))
  {
    if (const auto info = m.instantiate<sensor_msgs::CameraInfo>())
    {
      frames.addInfo(info);
      continue;
    }
    const auto image = m.instantiate<sensor_msgs::Image>();
    if (!image)
      continue;
    if (m.getTopic() == options.rgb_topic)
      frames.addRgb(image);
    else if (m.getTopic() == options.depth_topic)
      frames.addDepth(image);
    else if (const auto camera = options.camera_of_topic.find(m.getTopic());
             survey && camera != options.camera_of_topic.end())
      if (const auto grey = toGrey(*image))
        survey->addFixedImage(camera->second, *grey, image->header.stamp.toSec());
  }
  return frames.framesWithoutPose();
}

// Both readers: the transforms, then the images.
Expected<SurveyBagReport> readBag(const std::string& path, const SurveyBagOptions& options, RgbdFrameSink sink,
                                  Survey* survey)
{
  rosbag::Bag bag;
  if (const std::string problem = openBag(bag, path); !problem.empty())
    return Error(ErrorCode::kInvalidInput, problem);
  try
  {
    const std::unique_ptr<tf2::BufferCore> tf = readTransforms(bag);
    SurveyBagReport report;
    report.frames_without_pose = readImages(bag, *tf, options, std::move(sink), survey);
    return report;
  }
  catch (const rosbag::BagException& e)
  {
    // A bag cut short (a recording killed before it closed the file) fails while it is read.
    return Error(ErrorCode::kInvalidInput, path + ": the bag cannot be read to its end: " + e.what() + kReindexHint);
  }
}

}  // namespace

Expected<SurveyBagReport> readSurveyBag(const std::string& path, const SurveyBagOptions& options, Survey* survey)
{
  return readBag(
      path, options,
      [survey](const RgbdFrame& frame, const std::optional<Eigen::Isometry3d>& odometry) {
        survey->addRgbdFrame(frame, odometry);
      },
      survey);
}

Expected<SurveyBagReport> readSurveyRgbdFrames(const std::string& path, const SurveyBagOptions& options,
                                               const std::function<void(const RgbdFrame&)>& sink)
{
  return readBag(
      path, options, [&sink](const RgbdFrame& frame, const std::optional<Eigen::Isometry3d>&) { sink(frame); },
      nullptr);
}

}  // namespace insitu_calibration
