// The matcher's diagnostic trace (LineMatcherOptions::trace): printf-style lines, and a camera in one line.
#ifndef INSITU_CALIBRATION_MATCHING_MATCHER_TRACE_H
#define INSITU_CALIBRATION_MATCHING_MATCHER_TRACE_H

#include <cstdio>
#include <string>

#include "insitu_calibration/matching/line_matcher.h"

namespace insitu_calibration
{
namespace matching
{
template <typename... Args>
void trace(const LineMatcherOptions& options, const char* format, Args... args)
{
  if (!options.trace)
    return;
  char buffer[512];
  std::snprintf(buffer, sizeof(buffer), format, args...);
  options.trace(buffer);
}

std::string describeCamera(const CameraModel& camera);
}  // namespace matching
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_MATCHING_MATCHER_TRACE_H
