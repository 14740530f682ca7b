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
Expected<CorrespondenceSet> loadCorrespondenceFile(const std::string& path);
Expected<CorrespondenceSet> parseCorrespondences(const std::string& yaml_text);
// Written atomically (temporary file, then rename).
Status saveCorrespondenceFile(const std::string& path, const CorrespondenceSet& data);
std::string formatCorrespondences(const CorrespondenceSet& data);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_IO_CORRESPONDENCE_FILE_H
