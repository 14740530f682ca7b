// The core libraries must not depend on ROS: no ROS header in their sources or public headers (except the ros/
// headers of the ROS layer), nor in the test support that the plain unit tests link.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>

namespace fs = std::filesystem;

TEST(Architecture, CoreIncludesNoRosHeader)
{
  const fs::path root(INSITU_SOURCE_DIR);
  const std::regex ros_include(
      R"(#\s*include\s*[<"](ros/|tf2_ros/|tf2/|sensor_msgs/|geometry_msgs/|std_msgs/|cv_bridge/|image_transport/|rosbag/|message_filters/|visualization_msgs/|pcl_conversions/|pcl_ros/))");
  size_t checked = 0;
  for (const fs::path& dir :
       {root / "src" / "core", root / "include" / "insitu_calibration", root / "test" / "support"})
  {
    ASSERT_TRUE(fs::is_directory(dir)) << dir;
    for (const auto& entry : fs::recursive_directory_iterator(dir))
    {
      if (!entry.is_regular_file())
        continue;
      if (entry.path().string().find("include/insitu_calibration/ros/") != std::string::npos)
        continue;
      std::ifstream in(entry.path());
      std::string line;
      int number = 0;
      while (std::getline(in, line))
      {
        ++number;
        EXPECT_FALSE(std::regex_search(line, ros_include)) << entry.path() << ":" << number << ": " << line;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 10u);
}
