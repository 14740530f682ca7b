// The correspondence file read by calibrate_lines (format in README.md, "Correspondence file"):
//   camera_name: lobby_cam      # optional
//   image_width: 1280
//   image_height: 960
//   lines:
//     - image: [[u, v], [u, v], ...]     # >= 2 distorted pixels along the image of the line, in order
//       world: [[x, y, z], ...]          # >= 1 points on the 3D line, metres
//   points:                              # optional
//     - image: [u, v]
//       world: [x, y, z]
#ifndef INSITU_CALIBRATION_IO_CORRESPONDENCE_FILE_H
#define INSITU_CALIBRATION_IO_CORRESPONDENCE_FILE_H

#include <string>

#include "insitu_calibration/error.h"
#include "insitu_calibration/solvers/correspondences.h"

namespace insitu_calibration
{
// Documented limits (README, "Correspondence file"), checked before anything is allocated for the entries.
namespace correspondence_limits
{
constexpr int kMaxImageSide = 32768;         // px, image_width and image_height
constexpr size_t kMaxLines = 20000;          // entries of `lines`
constexpr size_t kMaxPoints = 20000;         // entries of `points`
constexpr size_t kMaxPointsPerLine = 10000;  // entries of a line's `image` or `world`
constexpr double kImageMargin = 1.0;         // image points within the image grown by its size on every side
constexpr double kMaxWorldM = 1e5;           // |x|, |y|, |z| of world points, metres
}  // namespace correspondence_limits

Expected<CorrespondenceSet> loadCorrespondenceFile(const std::string& path);
Expected<CorrespondenceSet> parseCorrespondences(const std::string& yaml_text);
// Written atomically (temporary file, then rename).
Status saveCorrespondenceFile(const std::string& path, const CorrespondenceSet& data);
std::string formatCorrespondences(const CorrespondenceSet& data);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_IO_CORRESPONDENCE_FILE_H
