// What the node publishes for rviz must be something rviz draws without reading past an array (issue 14: rviz
// aborted once under Xvfb with "free(): invalid next size"): the problems of a Marker, a MarkerArray and an Image,
// each in words (empty: well-formed).
#ifndef INSITU_CALIBRATION_TEST_ROS_MESSAGE_CHECKS_H
#define INSITU_CALIBRATION_TEST_ROS_MESSAGE_CHECKS_H

#include <cmath>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <visualization_msgs/MarkerArray.h>

namespace message_checks
{
inline bool finite(const geometry_msgs::Point& p)
{
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

inline std::vector<std::string> markerProblems(const visualization_msgs::Marker& m)
{
  using visualization_msgs::Marker;
  std::vector<std::string> problems;
  const std::string name = m.ns + "/" + std::to_string(m.id) + ": ";
  const auto problem = [&](const std::string& what) { problems.push_back(name + what); };
  if (m.header.frame_id.empty())
    problem("no frame_id");
  if (m.action == Marker::DELETE || m.action == Marker::DELETEALL)
    return problems;
  if (m.action != Marker::ADD)
    problem("unknown action " + std::to_string(m.action));
  const auto& q = m.pose.orientation;
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!finite(m.pose.position) || !(std::abs(norm - 1.0) < 1e-6))
    problem("pose not finite or quaternion not normalised (norm " + std::to_string(norm) + ")");
  const auto& c = m.color;
  for (const double channel : {c.r, c.g, c.b, c.a})
    if (!(channel >= 0.0 && channel <= 1.0))
      problem("colour channel outside [0, 1]");
  if (!(c.a > 0.0))
    problem("invisible (alpha 0)");
  if (!m.colors.empty() && m.colors.size() != m.points.size())
    problem(std::to_string(m.colors.size()) + " colours for " + std::to_string(m.points.size()) + " points");
  for (const auto& p : m.points)
    if (!finite(p))
    {
      problem("a point is not finite");
      break;
    }
  if (m.points.size() > 1000000)
    problem(std::to_string(m.points.size()) + " points");
  switch (m.type)
  {
    case Marker::LINE_LIST:
      if (m.points.empty() || m.points.size() % 2 != 0)
        problem("LINE_LIST with " + std::to_string(m.points.size()) + " points (needs a positive even count)");
      if (!(m.scale.x > 0.0 && std::isfinite(m.scale.x)))
        problem("line width scale.x not positive");
      break;
    case Marker::LINE_STRIP:
      if (m.points.size() < 2)
        problem("LINE_STRIP with fewer than 2 points");
      if (!(m.scale.x > 0.0 && std::isfinite(m.scale.x)))
        problem("line width scale.x not positive");
      break;
    case Marker::TEXT_VIEW_FACING:
      if (m.text.empty())
        problem("empty text");
      if (!(m.scale.z > 0.0 && std::isfinite(m.scale.z)))
        problem("text height scale.z not positive");
      break;
    default:
      if (!(m.scale.x > 0.0 && m.scale.y > 0.0 && m.scale.z > 0.0))
        problem("a scale not positive");
  }
  return problems;
}

inline std::vector<std::string> markerArrayProblems(const visualization_msgs::MarkerArray& array)
{
  std::vector<std::string> problems;
  std::set<std::pair<std::string, int>> seen;
  for (const auto& m : array.markers)
  {
    for (const std::string& p : markerProblems(m))
      problems.push_back(p);
    if (!seen.insert({m.ns, m.id}).second)
      problems.push_back(m.ns + "/" + std::to_string(m.id) + ": twice in one array");
  }
  return problems;
}

inline std::vector<std::string> imageProblems(const sensor_msgs::Image& image)
{
  namespace enc = sensor_msgs::image_encodings;
  std::vector<std::string> problems;
  if (image.header.frame_id.empty())
    problems.push_back("no frame_id");
  if (image.width == 0 || image.height == 0)
    problems.push_back("empty image");
  int bytes_per_pixel = 0;
  try
  {
    bytes_per_pixel = enc::numChannels(image.encoding) * enc::bitDepth(image.encoding) / 8;
  }
  catch (const std::exception& e)
  {
    problems.push_back("unknown encoding '" + image.encoding + "'");
    return problems;
  }
  if (image.step < image.width * bytes_per_pixel)
    problems.push_back("step " + std::to_string(image.step) + " below width x " + std::to_string(bytes_per_pixel));
  if (image.data.size() != static_cast<size_t>(image.step) * image.height)
    problems.push_back(std::to_string(image.data.size()) + " bytes of data for step x height " +
                       std::to_string(static_cast<size_t>(image.step) * image.height));
  return problems;
}
}  // namespace message_checks

#endif  // INSITU_CALIBRATION_TEST_ROS_MESSAGE_CHECKS_H
