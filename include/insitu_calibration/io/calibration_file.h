// The calibration YAML: camera_calibration_parsers' format (image_width, image_height, camera_name, camera_matrix,
// distortion_model, distortion_coefficients, rectification_matrix, projection_matrix), so every ROS tool reads it,
// plus our keys:
//   division_model: {lambda: L, center: [cx, cy]}                  the exact model, lambda in 1/px^2
//   world_projection_matrix: {rows: 3, cols: 4, data: [...]}       K [R | t], world metres -> undistorted pixels
//   camera_pose: {frame_id: map, position: [x, y, z], orientation: [qx, qy, qz, qw]}   optical frame in the world
//   quality: {rms_px, median_px, lines, points, constraints, distortion_estimated, ...}
#ifndef INSITU_CALIBRATION_IO_CALIBRATION_FILE_H
#define INSITU_CALIBRATION_IO_CALIBRATION_FILE_H

#include <map>
#include <optional>
#include <string>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/camera/plumb_bob.h"
#include "insitu_calibration/error.h"

namespace insitu_calibration
{
struct CalibrationQuality
{
  double rms_px = 0.0;
  double median_px = 0.0;
  size_t lines = 0;
  size_t points = 0;
  size_t constraints = 0;
  bool distortion_estimated = false;
  // Further named numbers (iterations, standard deviations, ...), written under quality: in key order.
  std::map<std::string, double> extra;
};

struct CalibrationFile
{
  std::string camera_name;
  int image_width = 0;
  int image_height = 0;
  std::string world_frame = "map";
  CameraModel camera;
  PlumbBobFit plumb_bob;  // filled by formatCalibration when left empty and lambda != 0
  std::optional<CalibrationQuality> quality;
};

std::string formatCalibration(const CalibrationFile& calibration);
// Written atomically: a reader sees the previous file or the new one, never a part.
Status saveCalibrationFile(const std::string& path, const CalibrationFile& calibration);
// Reads our format; a plain camera_calibration_parsers file without camera_pose is refused (it has no pose).
Expected<CalibrationFile> parseCalibration(const std::string& yaml_text);
Expected<CalibrationFile> loadCalibrationFile(const std::string& path);
// What parseCalibration checks of every file, loaded or about to be saved: an image of 1..32768 px a side, finite
// numbers everywhere, positive focal lengths, a principal point and distortion centre near the image, and a division
// model that does not fold the image (|lambda| r^2 < 1 at every corner: beyond it two pixels share a ray).
Status validateCalibration(const CalibrationFile& calibration);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_IO_CALIBRATION_FILE_H
