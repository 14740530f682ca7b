// libFuzzer harness: the camera list reader (config/cameras.yaml, calibration_node's ~cameras, calibrate_survey).
#include <cstddef>
#include <cstdint>
#include <string>

#include "insitu_calibration/survey/camera_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  (void)insitu_calibration::parseCameraConfig(std::string(reinterpret_cast<const char*>(data), size));
  return 0;
}
