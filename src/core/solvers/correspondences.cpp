#include "insitu_calibration/solvers/correspondences.h"

#include <algorithm>
#include <string>

namespace insitu_calibration
{
size_t CorrespondenceSet::lineConstraintCount() const
{
  size_t n = 0;
  for (const auto& line : lines)
    n += line.constraintCount();
  return n;
}

bool CorrespondenceSet::canIdentifyDistortion() const
{
  if (!points.empty())
    return true;
  for (const auto& line : lines)
    if (line.image.size() >= 3)
      return true;
  return false;
}

Status CorrespondenceSet::validate() const
{
  if (image_width <= 0 || image_height <= 0)
    return Error(ErrorCode::kInvalidInput, "image_width and image_height must be positive (got " +
                                               std::to_string(image_width) + " x " + std::to_string(image_height) +
                                               ")");
  for (size_t i = 0; i < lines.size(); ++i)
  {
    const auto& line = lines[i];
    const std::string where = "line " + std::to_string(i);
    if (line.image.size() < 2)
      return Error(ErrorCode::kInvalidInput,
                   where + ": its image needs at least 2 points, it has " + std::to_string(line.image.size()));
    if (line.world.empty())
      return Error(ErrorCode::kInvalidInput, where + ": it needs at least 1 world point");
    for (const auto& p : line.image)
      if (!p.allFinite())
        return Error(ErrorCode::kInvalidInput, where + ": an image point is NaN or infinite");
    for (const auto& p : line.world)
      if (!p.allFinite())
        return Error(ErrorCode::kInvalidInput, where + ": a world point is NaN or infinite");
    for (size_t j = 1; j < line.image.size(); ++j)
      if ((line.image[j] - line.image[j - 1]).norm() < 1e-9)
        return Error(ErrorCode::kInvalidInput, where + ": image points " + std::to_string(j - 1) + " and " +
                                                   std::to_string(j) + " coincide, so they define no line");
  }
  for (size_t i = 0; i < points.size(); ++i)
    if (!points[i].image.allFinite() || !points[i].world.allFinite())
      return Error(ErrorCode::kInvalidInput, "point " + std::to_string(i) + " is NaN or infinite");
  for (size_t i = 0; i < direction_lines.size(); ++i)
  {
    const auto& line = direction_lines[i];
    const bool finite = std::all_of(line.image.begin(), line.image.end(), [](const auto& p) { return p.allFinite(); });
    if (line.image.size() < 2 || !finite || !line.direction.allFinite() || !(line.direction.norm() > 1e-9))
      return Error(ErrorCode::kInvalidInput, "direction line " + std::to_string(i) +
                                                 ": it needs 2 or more finite image points and a non-zero direction");
  }
  return Success{};
}

}  // namespace insitu_calibration
