// Writing files so that readers see the old content or the new, never half of it: a temporary file in the same
// directory, flushed, then renamed over the target.
#ifndef INSITU_CALIBRATION_IO_ATOMIC_FILE_H
#define INSITU_CALIBRATION_IO_ATOMIC_FILE_H

#include <string>

#include "insitu_calibration/error.h"

namespace insitu_calibration
{
// Creates the parent directory when missing.
Status writeFileAtomically(const std::string& path, const std::string& content);
// Refuses a directory and a file larger than max_bytes (the readers' documented limit) before reading it.
Expected<std::string> readFile(const std::string& path, size_t max_bytes = size_t{64} << 20);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_IO_ATOMIC_FILE_H
