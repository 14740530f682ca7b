// camera_info.test: a calibrated fixed camera's images reach image_proc with our camera info and nothing else.
// The node (its calibration of cam_east loaded from the survey calibrated at build time by calibrate_survey)
// publishes, with every image the bag plays, the image and its camera info (same stamp and frame) in
// /fixed/cam_east/calibrated; image_proc runs in that namespace with no remapping; the simulator's true straight
// edges must be straight in image_rect. The same measurement on image_raw (where the lens bends them) shows that it
// sees a bend. Then ~save commits the calibration to a driver's set_camera_info (camera_info_manager's).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <optional>

#include <camera_info_manager/camera_info_manager.h>
#include <cv_bridge/cv_bridge.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_srvs/Trigger.h>

#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/simulation/true_edges.h"

namespace ic = insitu_calibration;

namespace
{
std::string g_truth_dir;
std::string g_work_dir;
std::string g_data_dir;  // where the node's calibration is (its output_directory's parent)
const char* const kNamespace = "/fixed/cam_east/calibrated";
constexpr size_t kImages = 5;
constexpr double kLongEdgePx = 400.0;  // the bend of shorter edges is within the image noise

// The last messages of each topic, and the headers of the camera infos seen.
struct Received
{
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<sensor_msgs::ImageConstPtr> raw, rect;  // the last kImages of each
  sensor_msgs::CameraInfoConstPtr info;
  std::map<double, std::string> info_headers, relayed_headers;  // stamp -> frame_id
  size_t relayed_count = 0;
};
Received g_received;

template <typename Pred>
bool waitFor(Pred pred, double seconds)
{
  std::unique_lock<std::mutex> lock(g_received.mutex);
  return g_received.changed.wait_for(lock, std::chrono::duration<double>(seconds), pred);
}

// The edge's bend: sub-pixel edge points (the gradient's peak across the edge) fitted with d = a + b s + c s^2
// across/along the points' principal axis; the sagitta |c| L^2 / 4 is how far the middle leaves the chord.
struct EdgeFit
{
  double sagitta_px = 0.0;
  double rms_px = 0.0;
  double length_px = 0.0;
  size_t points = 0;
};

double bilinear(const cv::Mat& image, const Eigen::Vector2d& p)
{
  const int x = static_cast<int>(std::floor(p.x())), y = static_cast<int>(std::floor(p.y()));
  const double fx = p.x() - x, fy = p.y() - y;
  auto at = [&](int xx, int yy) { return static_cast<double>(image.at<uint8_t>(yy, xx)); };
  return (1 - fy) * ((1 - fx) * at(x, y) + fx * at(x + 1, y)) + fy * ((1 - fx) * at(x, y + 1) + fx * at(x + 1, y + 1));
}

// The edge across p (normal n), to a fraction of a pixel: near the gradient's peak, where the intensity crosses
// halfway between its levels on either side (a step's 50 % point: no pull towards pixel centres, unlike the peak
// itself); nullopt when the step is weak or not inside the window.
std::optional<Eigen::Vector2d> edgePoint(const cv::Mat& grey, const Eigen::Vector2d& p, const Eigen::Vector2d& n)
{
  constexpr double kHalfWindow = 7.0, kStep = 0.25, kSearch = 4.0;
  const int count = static_cast<int>(2 * kHalfWindow / kStep) + 1;
  std::vector<double> intensity(count);
  for (int i = 0; i < count; ++i)
    intensity[i] = bilinear(grey, p + (-kHalfWindow + i * kStep) * n);
  const int side = static_cast<int>(2.0 / kStep), plateau = static_cast<int>(1.0 / kStep);
  int best = -1;
  double best_step = 0.0;
  for (int i = side + plateau; i < count - side - plateau; ++i)
  {
    if (std::abs(-kHalfWindow + i * kStep) > kSearch)
      continue;
    const double step = std::abs(intensity[i + 2] - intensity[i - 2]);
    if (step > best_step)
      best_step = step, best = i;
  }
  if (best < 0)
    return std::nullopt;
  double low = 0.0, high = 0.0;
  for (int j = 0; j < plateau; ++j)
  {
    low += intensity[best - side - j] / plateau;
    high += intensity[best + side + j] / plateau;
  }
  if (std::abs(high - low) < 20.0)
    return std::nullopt;
  const double mid = 0.5 * (low + high);
  for (int i = best - side; i < best + side; ++i)
    if ((intensity[i] - mid) * (intensity[i + 1] - mid) <= 0.0 && intensity[i] != intensity[i + 1])
    {
      const double s = -kHalfWindow + (i + (mid - intensity[i]) / (intensity[i + 1] - intensity[i])) * kStep;
      return p + s * n;
    }
  return std::nullopt;
}

// The bend of points along an edge: d = a + b s + c s^2 across/along their chord, fitted by least squares, then
// again without the points more than gate_px off (a neighbouring edge's gradient); nullopt when fewer than
// min_share of them remain.
std::optional<EdgeFit> fitBend(const std::vector<Eigen::Vector2d>& points, double gate_px, double min_share)
{
  if (points.size() < 10)
    return std::nullopt;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& q : points)
    mean += q / points.size();
  const Eigen::Vector2d along = (points.back() - points.front()).normalized();
  const Eigen::Vector2d across(-along.y(), along.x());
  std::vector<bool> inlier(points.size(), true);
  Eigen::Vector3d coefficients = Eigen::Vector3d::Zero();
  EdgeFit fit;
  for (int pass = 0; pass < 2; ++pass)
  {
    Eigen::MatrixXd a(points.size(), 3);
    Eigen::VectorXd b(points.size());
    int rows = 0;
    double s_min = 1e9, s_max = -1e9;
    for (size_t i = 0; i < points.size(); ++i)
    {
      if (!inlier[i])
        continue;
      const double s = (points[i] - mean).dot(along);
      a.row(rows) << 1.0, s, s * s;
      b(rows++) = (points[i] - mean).dot(across);
      s_min = std::min(s_min, s);
      s_max = std::max(s_max, s);
    }
    if (rows < 10)
      return std::nullopt;
    coefficients = a.topRows(rows).colPivHouseholderQr().solve(b.head(rows));
    const Eigen::VectorXd residual = a.topRows(rows) * coefficients - b.head(rows);
    fit.rms_px = std::sqrt(residual.squaredNorm() / rows);
    fit.length_px = s_max - s_min;
    fit.points = rows;
    for (size_t i = 0; i < points.size(); ++i)
    {
      const double s = (points[i] - mean).dot(along);
      inlier[i] = std::abs(coefficients(0) + coefficients(1) * s + coefficients(2) * s * s -
                           (points[i] - mean).dot(across)) < gate_px;
    }
  }
  if (fit.points < min_share * points.size())
    return std::nullopt;
  fit.sagitta_px = std::abs(coefficients(2)) * fit.length_px * fit.length_px / 4.0;
  return fit;
}

// The edge measured in an image: image_of(t), t in [0, 1], says where it is expected (within a few pixels).
std::optional<EdgeFit> measureEdge(const cv::Mat& grey, const std::function<Eigen::Vector2d(double)>& image_of)
{
  const double length = (image_of(1.0) - image_of(0.0)).norm();
  const int samples = static_cast<int>(length / 2.0);
  std::vector<Eigen::Vector2d> points;
  for (int i = 1; i < samples; ++i)
  {
    const double t = static_cast<double>(i) / samples, dt = 0.5 / samples;
    const Eigen::Vector2d p = image_of(t);
    const Eigen::Vector2d d = (image_of(t + dt) - image_of(t - dt)).normalized();
    if (p.x() < 10 || p.y() < 10 || p.x() > grey.cols - 11 || p.y() > grey.rows - 11)
      continue;
    if (const auto q = edgePoint(grey, p, Eigen::Vector2d(-d.y(), d.x())))
      points.push_back(*q);
  }
  if (points.size() < 40 || points.size() < 0.6 * samples)
    return std::nullopt;  // occluded or without contrast: not measured
  const auto fit = fitBend(points, 1.0, 0.0);
  if (!fit || fit->points < 0.6 * samples)
    return std::nullopt;
  return fit;
}

// Per-pixel median of grey images (people walking through vanish; the noise drops).
cv::Mat medianImage(const std::vector<cv::Mat>& images)
{
  cv::Mat out(images[0].size(), CV_8UC1);
  std::vector<uint8_t> values(images.size());
  for (int r = 0; r < out.rows; ++r)
    for (int c = 0; c < out.cols; ++c)
    {
      for (size_t i = 0; i < images.size(); ++i)
        values[i] = images[i].at<uint8_t>(r, c);
      std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
      out.at<uint8_t>(r, c) = values[values.size() / 2];
    }
  return out;
}

// The true edges cam_east sees, longer than 150 px, as [a, b] world segments of their visible part.
std::vector<ic::Segment3d> visibleEdges(const ic::CalibrationFile& truth)
{
  const auto edges = ic::simulation::loadTrueEdges(g_truth_dir + "/edges.yaml");
  EXPECT_TRUE(edges) << edges.error().describe();
  std::vector<ic::Segment3d> out;
  for (const auto& edge : edges ? *edges : std::vector<ic::simulation::TrueEdge>{})
  {
    if (edge.kind == "seam")
      continue;
    const ic::Segment3d segment{edge.start, edge.end};
    const auto interval = ic::visibleInterval(truth.camera, segment, truth.image_width, truth.image_height);
    if (!interval)
      continue;
    const ic::Segment3d part{segment.a + interval->first * (segment.b - segment.a),
                             segment.a + interval->second * (segment.b - segment.a)};
    const auto a = truth.camera.project(part.a), b = truth.camera.project(part.b);
    if (a && b && (*a - *b).norm() > 150.0)
      out.push_back(part);
  }
  return out;
}

struct Summary
{
  std::vector<EdgeFit> fits;
  double max_sagitta = 0.0;
  double median_sagitta = 0.0;
};

Summary summarize(std::vector<EdgeFit> fits)
{
  Summary s;
  s.fits = fits;
  std::sort(fits.begin(), fits.end(), [](const EdgeFit& x, const EdgeFit& y) { return x.sagitta_px < y.sagitta_px; });
  if (!fits.empty())
  {
    s.max_sagitta = fits.back().sagitta_px;
    s.median_sagitta = fits[fits.size() / 2].sagitta_px;
  }
  return s;
}
}  // namespace

TEST(CameraInfo, PublishedWithEveryImageSameHeader)
{
  ASSERT_TRUE(waitFor([] { return g_received.relayed_count >= 5; }, 60.0))
      << "no images relayed on " << kNamespace << "/image_raw: is cam_east's calibration loaded?";
  // Give the last camera infos a moment to arrive, then check that each relayed image had one with its header.
  ros::WallDuration(1.0).sleep();
  std::lock_guard<std::mutex> lock(g_received.mutex);
  size_t paired = 0;
  for (const auto& [stamp, frame_id] : g_received.relayed_headers)
  {
    const auto it = g_received.info_headers.find(stamp);
    paired += it != g_received.info_headers.end() && it->second == frame_id;
  }
  // All but possibly the last (its camera info may still be on its way).
  EXPECT_GE(paired + 1, g_received.relayed_headers.size())
      << "relayed images without a camera info of the same stamp and frame_id";
  ASSERT_TRUE(g_received.info);
  EXPECT_EQ(g_received.info->width, 1280u);
  EXPECT_EQ(g_received.info->height, 960u);
  EXPECT_EQ(g_received.info->distortion_model, "plumb_bob");
  std::printf("camera info: %zu relayed images, %zu with a camera info of the same header\n",
              g_received.relayed_headers.size(), paired);
}

TEST(CameraInfo, TrueEdgesStraightInImageRect)
{
  ASSERT_TRUE(waitFor([] { return g_received.rect.size() >= kImages && g_received.raw.size() >= kImages; }, 120.0))
      << "image_proc published no image_rect in " << kNamespace << " (it pairs image_raw and camera_info by stamp)";
  const auto truth = ic::loadCalibrationFile(g_truth_dir + "/cam_east.yaml");
  ASSERT_TRUE(truth) << truth.error().describe();
  std::vector<cv::Mat> rect_images, raw_images;
  sensor_msgs::CameraInfoConstPtr info;
  {
    std::lock_guard<std::mutex> lock(g_received.mutex);
    for (const auto& m : g_received.rect)
      rect_images.push_back(cv_bridge::toCvCopy(m, "mono8")->image);
    for (const auto& m : g_received.raw)
      raw_images.push_back(cv_bridge::toCvCopy(m, "mono8")->image);
    info = g_received.info;
  }
  const cv::Mat rect_grey = medianImage(rect_images), raw_grey = medianImage(raw_images);
  ASSERT_EQ(rect_grey.cols, truth->image_width);
  // image_rect is a pin-hole image with K = P of our camera info: where a true edge lies in it follows from the true
  // pose and that K (our calibration is close to the truth: the search window is +-5 px).
  cv::Matx33d k, p;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
    {
      k(r, c) = info->K[3 * r + c];
      p(r, c) = info->P[4 * r + c];
    }
  const ic::CameraPose& pose = truth->camera.pose();
  std::vector<EdgeFit> rect_fits, raw_fits, predicted_fits;
  for (const auto& edge : visibleEdges(*truth))
  {
    auto at = [&](double t) { return edge.a + t * (edge.b - edge.a); };
    // Noise-free: the true image of the edge (the true camera, its lens) rectified through our camera info as
    // image_proc does it (cv::undistortPoints with K, D and P), where nothing but our calibration can bend it.
    std::vector<cv::Point2d> distorted, rectified;
    for (int i = 0; i <= 200; ++i)
      if (const auto q = truth->camera.project(at(i / 200.0)))
        distorted.emplace_back(q->x(), q->y());
    cv::undistortPoints(distorted, rectified, k, info->D, cv::noArray(), p);
    std::vector<Eigen::Vector2d> rectified_points;
    for (const auto& q : rectified)
      rectified_points.emplace_back(q.x, q.y);
    const auto predicted = fitBend(rectified_points, 1e9, 1.0);
    ASSERT_TRUE(predicted);
    predicted_fits.push_back(*predicted);
    // Measured in image_rect and, for comparison, in image_raw.
    const auto in_rect = measureEdge(rect_grey, [&](double t) {
      const cv::Vec3d x = p * cv::Vec3d(Eigen::Vector3d(pose.rotation * at(t) + pose.translation).data());
      return Eigen::Vector2d(x[0] / x[2], x[1] / x[2]);
    });
    const auto in_raw = measureEdge(
        raw_grey, [&](double t) { return truth->camera.project(at(t)).value_or(Eigen::Vector2d(-100, -100)); });
    std::printf(
        "edge %4.0f px: through our camera info %.3f px; measured in image_rect %s, in image_raw %s\n",
        predicted->length_px, predicted->sagitta_px,
        in_rect ? cv::format("%.3f px (rms %.3f, %zu points)", in_rect->sagitta_px, in_rect->rms_px, in_rect->points)
                      .c_str()
                : "-",
        in_raw ? cv::format("%.3f px", in_raw->sagitta_px).c_str() : "-");
    if (in_rect && in_raw && in_rect->length_px >= kLongEdgePx)
    {
      rect_fits.push_back(*in_rect);
      raw_fits.push_back(*in_raw);
    }
  }
  const Summary predicted = summarize(predicted_fits), in_rect = summarize(rect_fits), in_raw = summarize(raw_fits);
  std::printf(
      "sagitta of the true edges: through our camera info (%zu edges) median %.3f max %.3f px; measured on "
      "the %zu edges over %.0f px: image_rect median %.3f max %.3f px, image_raw median %.3f max %.3f px\n",
      predicted_fits.size(), predicted.median_sagitta, predicted.max_sagitta, rect_fits.size(), kLongEdgePx,
      in_rect.median_sagitta, in_rect.max_sagitta, in_raw.median_sagitta, in_raw.max_sagitta);
  ASSERT_GE(predicted_fits.size(), 10u);
  EXPECT_LT(predicted.max_sagitta, 0.1) << "our camera info leaves a true straight edge bent";
  ASSERT_GE(rect_fits.size(), 5u) << "too few long true edges measured in the images to say anything";
  EXPECT_LT(in_rect.median_sagitta, 0.1) << "true straight edges are bent in image_rect";
  // The measurement sees the lens: in image_raw the same edges bend.
  EXPECT_GT(in_raw.median_sagitta, 3 * in_rect.median_sagitta);
}

TEST(CameraInfo, SaveCommitsToTheDriver)
{
  // A driver's side of set_camera_info: camera_info_manager, storing what it receives in a file.
  const std::string url = "file://" + g_work_dir + "/driver_cam_east.yaml";
  std::filesystem::remove(g_work_dir + "/driver_cam_east.yaml");
  camera_info_manager::CameraInfoManager driver(ros::NodeHandle("/fixed/cam_east"), "cam_east", url);
  ASSERT_TRUE(ros::service::waitForService("/fixed/cam_east/set_camera_info", ros::Duration(10.0)));
  ASSERT_TRUE(ros::service::waitForService("/calibration_node/save", ros::Duration(30.0)));
  std_srvs::Trigger save;
  ASSERT_TRUE(ros::service::call("/calibration_node/save", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  EXPECT_NE(save.response.message.find("cam_east committed to /fixed/cam_east/set_camera_info"), std::string::npos)
      << save.response.message;
  const sensor_msgs::CameraInfo committed = driver.getCameraInfo();
  sensor_msgs::CameraInfoConstPtr ours;
  {
    std::lock_guard<std::mutex> lock(g_received.mutex);
    ours = g_received.info;
  }
  ASSERT_TRUE(ours);
  for (int i = 0; i < 9; ++i)
    EXPECT_DOUBLE_EQ(committed.K[i], ours->K[i]);
  ASSERT_EQ(committed.D.size(), ours->D.size());
  for (size_t i = 0; i < ours->D.size(); ++i)
    EXPECT_DOUBLE_EQ(committed.D[i], ours->D[i]);
  EXPECT_TRUE(std::filesystem::exists(g_work_dir + "/driver_cam_east.yaml")) << "the driver did not store it";
}

TEST(CameraInfo, OurYamlServesAsCameraInfoUrl)
{
  // A driver given our calibration file as its camera_info_url (camera_info_manager reads it with
  // camera_calibration_parsers) publishes our camera info.
  ASSERT_TRUE(waitFor([] { return g_received.info != nullptr; }, 60.0));
  camera_info_manager::CameraInfoManager driver(ros::NodeHandle("/fixed/cam_east_url"), "cam_east",
                                                "file://" + g_data_dir + "/camera_info_calibration/cam_east.yaml");
  ASSERT_TRUE(driver.isCalibrated());
  const sensor_msgs::CameraInfo loaded = driver.getCameraInfo();
  sensor_msgs::CameraInfoConstPtr ours;
  {
    std::lock_guard<std::mutex> lock(g_received.mutex);
    ours = g_received.info;
  }
  EXPECT_EQ(loaded.width, ours->width);
  EXPECT_EQ(loaded.height, ours->height);
  EXPECT_EQ(loaded.distortion_model, ours->distortion_model);
  for (int i = 0; i < 9; ++i)
    EXPECT_NEAR(loaded.K[i], ours->K[i], 1e-6 * std::max(1.0, std::abs(ours->K[i])));
  for (int i = 0; i < 12; ++i)
    EXPECT_NEAR(loaded.P[i], ours->P[i], 1e-6 * std::max(1.0, std::abs(ours->P[i])));
  ASSERT_EQ(loaded.D.size(), ours->D.size());
  for (size_t i = 0; i < ours->D.size(); ++i)
    EXPECT_NEAR(loaded.D[i], ours->D[i], 1e-9);
}

void keepLast(std::vector<sensor_msgs::ImageConstPtr>* images, const sensor_msgs::ImageConstPtr& image)
{
  images->push_back(image);
  if (images->size() > kImages)
    images->erase(images->begin());
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_camera_info");
  ros::NodeHandle nh, private_nh("~");
  private_nh.getParam("truth_dir", g_truth_dir);
  private_nh.getParam("work_dir", g_work_dir);
  private_nh.getParam("data_dir", g_data_dir);
  std::filesystem::create_directories(g_work_dir);
  auto notify = [](auto&& update) {
    {
      std::lock_guard<std::mutex> lock(g_received.mutex);
      update();
    }
    g_received.changed.notify_all();
  };
  ros::Subscriber raw = nh.subscribe<sensor_msgs::Image>(
      "/fixed/cam_east/image_raw", 2,
      [&](const sensor_msgs::ImageConstPtr& m) { notify([&] { keepLast(&g_received.raw, m); }); });
  ros::Subscriber rect = nh.subscribe<sensor_msgs::Image>(
      std::string(kNamespace) + "/image_rect", 2,
      [&](const sensor_msgs::ImageConstPtr& m) { notify([&] { keepLast(&g_received.rect, m); }); });
  ros::Subscriber info = nh.subscribe<sensor_msgs::CameraInfo>(
      std::string(kNamespace) + "/camera_info", 20, [&](const sensor_msgs::CameraInfoConstPtr& m) {
        notify([&] {
          g_received.info = m;
          g_received.info_headers[m->header.stamp.toSec()] = m->header.frame_id;
        });
      });
  ros::Subscriber relayed = nh.subscribe<sensor_msgs::Image>(
      std::string(kNamespace) + "/image_raw", 20, [&](const sensor_msgs::ImageConstPtr& m) {
        notify([&] {
          ++g_received.relayed_count;
          g_received.relayed_headers[m->header.stamp.toSec()] = m->header.frame_id;
        });
      });
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
