#include "insitu_calibration/io/vgg_dataset.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <Eigen/LU>

namespace insitu_calibration
{
namespace
{
namespace fs = std::filesystem;

// Rows of whitespace-separated numbers; each row must have at least min_columns.
Expected<std::vector<std::vector<double>>> readNumberRows(const fs::path& path, size_t min_columns)
{
  std::ifstream in(path);
  if (!in)
    return Error(ErrorCode::kIoError, "cannot open " + path.string());
  std::vector<std::vector<double>> rows;
  std::string text;
  size_t line_number = 0;
  while (std::getline(in, text))
  {
    ++line_number;
    std::istringstream ss(text);
    std::vector<double> row;
    double x;
    while (ss >> x)
      row.push_back(x);
    if (row.empty())
      continue;
    if (row.size() < min_columns)
      return Error(ErrorCode::kParseError, path.string() + ":" + std::to_string(line_number) + ": expected " +
                                               std::to_string(min_columns) + " numbers");
    rows.push_back(std::move(row));
  }
  return rows;
}

Expected<fs::path> findBySuffix(const fs::path& directory, const std::string& suffix)
{
  for (const auto& entry : fs::directory_iterator(directory))
  {
    const std::string name = entry.path().filename().string();
    if (name.size() >= suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0 &&
        name.find("nview") == std::string::npos)
      return entry.path();
  }
  return Error(ErrorCode::kIoError, "no *" + suffix + " file in " + directory.string());
}

// nview-lines: one row per 3D line, one column per view, '*' where unseen (-1).
Expected<std::vector<std::vector<long>>> readViewMatches(const fs::path& path)
{
  std::ifstream nview(path);
  std::vector<std::vector<long>> matches;
  std::string text;
  while (std::getline(nview, text))
  {
    std::istringstream ss(text);
    std::vector<long> row;
    std::string token;
    while (ss >> token)
    {
      char* end = nullptr;
      const long index = token == "*" ? -1 : std::strtol(token.c_str(), &end, 10);
      if (token != "*" && (*end != '\0' || index < 0))
        return Error(ErrorCode::kParseError, path.string() + ": '" + token + "' is neither an index nor '*'");
      row.push_back(index);
    }
    if (!row.empty())
      matches.push_back(std::move(row));
  }
  return matches;
}

// One view: its projection matrix (<name>.P) and its correspondences, each 3D line (row k of segments) seen in it
// paired with its image line (<name>.lines).
Expected<VggView> readView(const fs::path& p_file, const std::vector<std::vector<double>>& segments,
                           const std::vector<std::vector<long>>& matches, size_t v, const fs::path& nview_path,
                           int image_width, int image_height)
{
  VggView view;
  view.name = p_file.stem().string();
  const auto p = readNumberRows(p_file, 4);
  if (!p)
    return p.error();
  if (p->size() != 3)
    return Error(ErrorCode::kParseError, p_file.string() + ": expected 3 rows of 4 numbers");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      view.projection(r, c) = (*p)[r][c];
  fs::path lines_path = p_file;
  lines_path.replace_extension(".lines");
  const auto lines2d = readNumberRows(lines_path, 4);
  if (!lines2d)
    return lines2d.error();
  view.data.camera_name = view.name;
  view.data.image_width = image_width;
  view.data.image_height = image_height;
  for (size_t k = 0; k < matches.size(); ++k)
  {
    if (v >= matches[k].size() || matches[k][v] < 0)
      continue;
    const size_t index = static_cast<size_t>(matches[k][v]);
    if (index >= lines2d->size())
      return Error(ErrorCode::kParseError, nview_path.string() + ": line " + std::to_string(index) +
                                               " does not exist in " + lines_path.string());
    const auto& s2 = (*lines2d)[index];
    const auto& s3 = segments[k];
    LineCorrespondence line;
    line.image = {Eigen::Vector2d(s2[0], s2[1]), Eigen::Vector2d(s2[2], s2[3])};
    line.world = {Eigen::Vector3d(s3[0], s3[1], s3[2]), Eigen::Vector3d(s3[3], s3[4], s3[5])};
    view.data.lines.push_back(std::move(line));
  }
  return view;
}

// Handedness from the first view: det(M) and the depth sign of the scene must agree in a right-handed frame; a
// left-handed scene is mirrored in z (VggView::mirrored).
void mirrorIfLeftHanded(const std::vector<std::vector<double>>& segments, std::vector<VggView>* views)
{
  const Matrix34d& p0 = views->front().projection;
  double depth_sign = 0.0;
  for (const auto& s3 : segments)
    depth_sign += (p0 * Eigen::Vector4d(s3[0], s3[1], s3[2], 1.0))(2) > 0.0 ? 1.0 : -1.0;
  if (!(p0.leftCols<3>().determinant() * depth_sign < 0.0))
    return;
  const Eigen::Vector4d mirror(1.0, 1.0, -1.0, 1.0);
  for (auto& view : *views)
  {
    view.mirrored = true;
    view.projection = view.projection * mirror.asDiagonal();
    for (auto& line : view.data.lines)
      for (auto& x : line.world)
        x.z() = -x.z();
  }
}
}  // namespace

Expected<std::vector<VggView>> loadVggScene(const std::string& directory, int image_width, int image_height)
{
  const fs::path dir(directory);
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    return Error(ErrorCode::kIoError, directory + " is not a directory");
  std::vector<fs::path> p_files;
  fs::path nview_path;
  for (const auto& entry : fs::directory_iterator(dir))
  {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() == ".P")
      p_files.push_back(entry.path());
    if (name.size() >= 11 && name.compare(name.size() - 11, 11, "nview-lines") == 0)
      nview_path = entry.path();
  }
  std::sort(p_files.begin(), p_files.end());
  if (p_files.empty() || nview_path.empty())
    return Error(ErrorCode::kIoError, directory + ": needs *.P files and an nview-lines file");
  const auto l3d_path = findBySuffix(dir, "l3d");
  if (!l3d_path)
    return l3d_path.error();
  const auto segments = readNumberRows(*l3d_path, 6);
  if (!segments)
    return segments.error();
  const auto matches = readViewMatches(nview_path);
  if (!matches)
    return matches.error();
  if (matches->size() != segments->size())
    return Error(ErrorCode::kParseError, nview_path.string() + " has " + std::to_string(matches->size()) +
                                             " rows but the 3D line file has " + std::to_string(segments->size()));
  std::vector<VggView> views;
  for (size_t v = 0; v < p_files.size(); ++v)
  {
    auto view = readView(p_files[v], *segments, *matches, v, nview_path, image_width, image_height);
    if (!view)
      return view.error();
    views.push_back(std::move(*view));
  }
  mirrorIfLeftHanded(*segments, &views);
  return views;
}

}  // namespace insitu_calibration
