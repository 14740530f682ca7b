// libFuzzer harness: the calibration file reader. What it accepts must survive a save and a reload unchanged in
// validity (a saved calibration the node could not reload would be lost at the next restart).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "insitu_calibration/io/calibration_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  namespace ic = insitu_calibration;
  const auto file = ic::parseCalibration(std::string(reinterpret_cast<const char*>(data), size));
  if (!file)
    return 0;
  const auto reloaded = ic::parseCalibration(ic::formatCalibration(*file));
  if (!reloaded)
    std::abort();  // a file we accept and write must read back
  return 0;
}
