// libFuzzer harness: the correspondence file reader, then the linear DLT on what it accepts (where the 1e155 px
// coordinates hung Eigen's QZ).
#include <cstddef>
#include <cstdint>
#include <string>

#include "insitu_calibration/calibration.h"
#include "insitu_calibration/io/correspondence_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  namespace ic = insitu_calibration;
  const auto set = ic::parseCorrespondences(std::string(reinterpret_cast<const char*>(data), size));
  if (!set || set->lines.size() + set->points.size() > 64)
    return 0;
  ic::CalibrationOptions options;
  options.ransac = false;
  options.refine = false;
  (void)ic::calibrateCamera(*set, options);
  return 0;
}
