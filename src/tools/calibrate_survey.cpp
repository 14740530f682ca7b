// calibrate_survey: the calibration node's pipeline run offline on a recorded survey bag, without a ROS master:
// the Xtion's frames (with the poses of /tf and /tf_static) build the line map, the fixed cameras' images their
// medians, and every configured camera is calibrated and written like the node writes it.
#include <chrono>
#include <deque>
#include <iostream>

#include <opencv2/imgcodecs.hpp>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include "command_line.h"
#include "insitu_calibration/refine/refinement.h"
#include "insitu_calibration/lines/line_evaluation.h"
#include "insitu_calibration/metrics.h"
#include "insitu_calibration/ros/conversions.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "insitu_calibration/survey/camera_config.h"
#include "insitu_calibration/survey/overlay.h"
#include "insitu_calibration/survey/survey.h"

namespace ic = insitu_calibration;

namespace
{
const char* kUsage = R"(Usage: calibrate_survey BAG --cameras CAMERAS.yaml --out-dir DIR [options]

Runs the calibration node's pipeline offline on a survey bag (no ROS master needed): keyframes of the Xtion
(/camera/rgb/image_raw, /camera/depth_registered/image_raw, /camera/rgb/camera_info, posed with /tf and /tf_static
in the world frame) build the 3D line map; each configured fixed camera's images (its image_topic) build its temporal
median; then every camera is calibrated (prior matching or correspondence file) and DIR/<camera>.yaml and
DIR/<camera>_overlay.png are written, as the node writes them.

Options:
  --cameras FILE        fixed-camera configuration (config/cameras.yaml format)
  --out-dir DIR         where to write the calibrations
  --world-frame NAME    default map
  --min-support N       map lines seen fewer times are not used (default 2)
  --camera NAME         calibrate only this camera
  --search-starts N     distinct results of the prior search refined per camera (default 4)
  --truth-dir DIR       the simulator's truth folder (<bag>_truth): also report, per camera, how many matches pair
                        the wrong edges and how far the matched map lines are from the true edges
  --no-refine           the paper's linear DLT after matching (no Ceres refinement)
  --no-ransac           no RANSAC over the matched lines
  --quiet               print only errors and the result table

Exit status: 0 when every camera calibrated, 1 when one failed, 2 on bad arguments or an unreadable bag.
)";

// Diagnostics against the simulator's truth: the true edge of each matched image line (under the true camera) and
// of each matched map line; a match is wrong when they differ.
void reportAgainstTruth(const std::string& truth_dir, const std::string& name, const ic::FixedCameraResult& result)
{
  const auto truth = ic::loadCalibrationFile(truth_dir + "/" + name + ".yaml");
  const auto edges = ic::simulation::loadTrueEdges(truth_dir + "/edges.yaml");
  if (!truth || !edges)
  {
    std::printf("  truth: %s\n", (!truth ? truth.error() : edges.error()).describe().c_str());
    return;
  }
  std::vector<ic::Segment3d> segments;
  for (const auto& e : *edges)
    segments.push_back({e.start, e.end});
  const auto images = ic::projectEdges(truth->camera, segments);
  size_t wrong = 0, unknown_image = 0, unknown_map = 0;
  std::vector<double> map_errors_mm;
  for (size_t k = 0; k < result.matched_image_lines.size(); ++k)
  {
    const ic::ImageLineError image_error =
        ic::measureImageLine(result.matched_image_lines[k], truth->camera.distortion(), images, 3.0, 1.0, 0.6);
    const ic::Segment3d& m = result.matched_map_lines[k];
    const ic::Line3dError map_error = ic::measureLine3d(m.a, m.b, segments, 0.1, 5.0);
    if (map_error.edge < 0)
      ++unknown_map;
    else
      map_errors_mm.push_back(1000.0 * map_error.distance_m);
    if (image_error.edge < 0)
      ++unknown_image;
    else if (map_error.edge >= 0)
    {
      // Collinear true edges (one straight line split in two) are the same line for calibration.
      const ic::Segment3d& a = segments[image_error.edge];
      const ic::Segment3d& b = segments[map_error.edge];
      const Eigen::Vector3d d = (a.b - a.a).normalized();
      const bool collinear =
          std::abs(d.dot((b.b - b.a).normalized())) > 0.9999 && ((b.a - a.a) - d * d.dot(b.a - a.a)).norm() < 1e-3;
      wrong += (image_error.edge != map_error.edge && !collinear) ? 1 : 0;
    }
  }
  const ic::ReprojectionStats map_stats = ic::summarize(map_errors_mm);
  std::printf(
      "  truth: %zu matches, %zu pair different edges, %zu image lines and %zu map lines on no true edge; "
      "matched map lines off their edge by median %.2f mm, max %.2f mm\n",
      result.matched_image_lines.size(), wrong, unknown_image, unknown_map, map_stats.median_px, map_stats.max_px);
}

double seconds(std::chrono::steady_clock::time_point start)
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

int main(int argc, char** argv)
{
  ic::quietSolverLogging();
  ic::CommandLine cli(argc, argv,
                      {"cameras", "out-dir", "world-frame", "min-support", "camera", "search-starts", "truth-dir"},
                      {"no-refine", "no-ransac", "quiet"});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  const int min_support = static_cast<int>(cli.number("min-support", 2));
  if (!cli.error().empty() || cli.positional().size() != 1 || !cli.has("cameras") || !cli.has("out-dir"))
  {
    std::cerr << "calibrate_survey: "
              << (cli.error().empty() ? "BAG, --cameras and --out-dir are required" : cli.error()) << "\n\n"
              << kUsage;
    return 2;
  }
  const bool quiet = cli.flag("quiet");
  const std::string world_frame = cli.value("world-frame", "map");
  const std::string out_dir = cli.value("out-dir");
  const auto configs = ic::loadCameraConfig(cli.value("cameras"));
  if (!configs)
  {
    std::cerr << "calibrate_survey: " << configs.error().describe() << "\n";
    return 2;
  }
  ic::SurveyOptions options;
  options.min_map_support = min_support;
  options.cameras.matcher.calibration.refine = !cli.flag("no-refine");
  options.cameras.matcher.calibration.ransac = !cli.flag("no-ransac");
  options.cameras.matcher.search_starts = static_cast<int>(cli.number("search-starts", 4));
  std::vector<ic::FixedCameraConfig> cameras;
  std::map<std::string, std::string> topic_to_camera;
  for (const auto& entry : *configs)
  {
    cameras.push_back(entry.camera);
    topic_to_camera[entry.camera.image_topic] = entry.camera.name;
  }
  ic::Survey survey(cameras, options);

  rosbag::Bag bag;
  try
  {
    bag.open(cli.positional()[0], rosbag::bagmode::Read);
  }
  catch (const rosbag::BagException& e)
  {
    std::cerr << "calibrate_survey: cannot open " << cli.positional()[0] << ": " << e.what() << "\n";
    return 2;
  }
  const auto start = std::chrono::steady_clock::now();

  // Pass 1: every transform, so that each frame finds its pose whatever the order of the messages.
  rosbag::View all(bag);
  const ros::Duration span = all.getEndTime() - all.getBeginTime();
  tf2::BufferCore tf(span + ros::Duration(10.0));
  for (const auto& m : rosbag::View(bag, rosbag::TopicQuery(std::vector<std::string>{"/tf", "/tf_static"})))
  {
    const auto msg = m.instantiate<tf2_msgs::TFMessage>();
    if (!msg)
      continue;
    const bool is_static = m.getTopic() == "/tf_static";
    for (const auto& t : msg->transforms)
      tf.setTransform(t, "bag", is_static);
  }

  // Pass 2: RGB-D frames (matched by stamp) and fixed-camera images.
  std::vector<std::string> topics = {"/camera/rgb/image_raw", "/camera/depth_registered/image_raw",
                                     "/camera/rgb/camera_info"};
  for (const auto& [topic, name] : topic_to_camera)
    topics.push_back(topic);
  std::map<ros::Time, sensor_msgs::ImageConstPtr> rgbs;
  std::map<ros::Time, sensor_msgs::ImageConstPtr> depths;
  std::map<ros::Time, sensor_msgs::CameraInfoConstPtr> infos;
  size_t no_pose = 0;
  const auto tryFrame = [&](const ros::Time& stamp) {
    if (!rgbs.count(stamp) || !depths.count(stamp) || !infos.count(stamp))
      return;
    const auto rgb = rgbs[stamp];
    geometry_msgs::TransformStamped pose;
    try
    {
      pose = tf.lookupTransform(world_frame, rgb->header.frame_id, stamp);
    }
    catch (const tf2::TransformException&)
    {
      ++no_pose;
      rgbs.erase(stamp);
      return;
    }
    const auto frame = ic::toRgbdFrame(*rgb, *depths[stamp], *infos[stamp], ic::toEigen(pose.transform));
    if (frame)
      survey.addRgbdFrame(*frame);
    rgbs.erase(stamp);
    depths.erase(stamp);
    infos.erase(stamp);
  };
  for (const auto& m : rosbag::View(bag, rosbag::TopicQuery(topics)))
  {
    if (const auto info = m.instantiate<sensor_msgs::CameraInfo>())
    {
      infos[info->header.stamp] = info;
      tryFrame(info->header.stamp);
      continue;
    }
    const auto image = m.instantiate<sensor_msgs::Image>();
    if (!image)
      continue;
    if (m.getTopic() == "/camera/rgb/image_raw")
    {
      rgbs[image->header.stamp] = image;
      tryFrame(image->header.stamp);
    }
    else if (m.getTopic() == "/camera/depth_registered/image_raw")
    {
      depths[image->header.stamp] = image;
      tryFrame(image->header.stamp);
    }
    else if (topic_to_camera.count(m.getTopic()))
    {
      const auto grey = ic::toGrey(*image);
      if (grey)
        survey.addFixedImage(topic_to_camera[m.getTopic()], *grey, image->header.stamp.toSec());
    }
  }
  const double survey_s = seconds(start);
  const ic::SurveyStats& stats = survey.stats();
  if (!quiet)
    std::printf(
        "survey: %zu RGB-D frames, %zu keyframes, %zu 3D lines, %zu map lines (%zu seen %d+ times), %zu "
        "frames without a pose; %.1f s\n",
        stats.frames, stats.keyframes, stats.lines, survey.lineMap().size(), survey.mapSegments().size(), min_support,
        no_pose, survey_s);

  int status = 0;
  const std::vector<ic::Segment3d> map = survey.mapSegments();
  for (const auto& name : survey.cameraNames())
  {
    if (cli.has("camera") && cli.value("camera") != name)
      continue;
    const auto calibration_start = std::chrono::steady_clock::now();
    ic::FixedCamera& camera = survey.camera(name);
    const auto result = camera.calibrate(map, world_frame);
    if (!result)
    {
      std::printf("%s: FAILED: %s\n", name.c_str(), result.error().describe().c_str());
      status = 1;
      continue;
    }
    const std::string path = out_dir + "/" + name + ".yaml";
    if (const ic::Status saved = ic::saveCalibrationFile(path, result->file); !saved)
    {
      std::printf("%s: %s\n", name.c_str(), saved.error().describe().c_str());
      status = 1;
      continue;
    }
    cv::imwrite(out_dir + "/" + name + "_overlay.png",
                ic::drawOverlay(camera.medianImage(), result->file.image_width, result->file.image_height,
                                result->file.camera, map, result->matched_image_lines));
    std::printf("%s: %s (%.1f s) -> %s\n", name.c_str(), result->summary.c_str(), seconds(calibration_start),
                path.c_str());
    if (cli.has("truth-dir"))
      reportAgainstTruth(cli.value("truth-dir"), name, *result);
  }
  return status;
}
