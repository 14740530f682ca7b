// The fixed-camera configuration (config/cameras.yaml, documented there): a list `cameras:` of name, image_topic,
// image size, and a prior or a correspondence file. The node reads it from its private parameters, offline tools
// from the file; both parse it here.
#ifndef INSITU_CALIBRATION_SURVEY_CAMERA_CONFIG_H
#define INSITU_CALIBRATION_SURVEY_CAMERA_CONFIG_H

#include <string>
#include <vector>

#include "insitu_calibration/error.h"
#include "insitu_calibration/survey/fixed_camera.h"

namespace insitu_calibration
{
struct CameraConfigEntry
{
  FixedCameraConfig camera;
  std::string calibrated_info_topic;  // default: beside image_topic, camera_info_calibrated
};

// yaml_text holds a map with the key `cameras` (or is the list itself). Errors name the entry and the key.
Expected<std::vector<CameraConfigEntry>> parseCameraConfig(const std::string& yaml_text);
Expected<std::vector<CameraConfigEntry>> loadCameraConfig(const std::string& path);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_CAMERA_CONFIG_H
