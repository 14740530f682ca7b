#include "insitu_calibration/error.h"

namespace insitu_calibration
{
const char* toString(ErrorCode code)
{
  switch (code)
  {
    case ErrorCode::kInvalidInput:
      return "invalid input";
    case ErrorCode::kNotEnoughData:
      return "not enough data";
    case ErrorCode::kDegenerate:
      return "degenerate";
    case ErrorCode::kNoSolution:
      return "no solution";
    case ErrorCode::kIoError:
      return "I/O error";
    case ErrorCode::kParseError:
      return "parse error";
  }
  return "error";
}

}  // namespace insitu_calibration
