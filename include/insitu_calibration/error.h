// The one error style of the core library: functions that can fail return Expected<T>, which holds either a value
// or an Error (a code and a message a user can act on). Nothing in the core throws across its API.
#ifndef INSITU_CALIBRATION_ERROR_H
#define INSITU_CALIBRATION_ERROR_H

#include <string>
#include <utility>
#include <variant>

namespace insitu_calibration
{
enum class ErrorCode
{
  kInvalidInput,   // NaN, infinite or malformed values, wrong sizes
  kNotEnoughData,  // fewer constraints than the model needs
  kDegenerate,     // enough data, but a configuration that does not determine the model
  kNoSolution,     // the numerical method found no acceptable solution
  kIoError,        // a file could not be read or written
  kParseError,     // a file was read but its content is not in the expected format
};

const char* toString(ErrorCode code);

class Error
{
public:
  Error(ErrorCode code, std::string message) : code_(code), message_(std::move(message)) {}

  ErrorCode code() const { return code_; }
  const std::string& message() const { return message_; }
  // "degenerate: all 3D lines are parallel"
  std::string describe() const { return std::string(toString(code_)) + ": " + message_; }

private:
  ErrorCode code_;
  std::string message_;
};

template <typename T>
class Expected
{
public:
  Expected(T value) : storage_(std::move(value)) {}      // NOLINT: implicit by design, like std::expected
  Expected(Error error) : storage_(std::move(error)) {}  // NOLINT

  bool ok() const { return storage_.index() == 0; }
  explicit operator bool() const { return ok(); }

  const T& value() const& { return std::get<0>(storage_); }
  T& value() & { return std::get<0>(storage_); }
  T&& value() && { return std::get<0>(std::move(storage_)); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

  const Error& error() const { return std::get<1>(storage_); }

private:
  std::variant<T, Error> storage_;
};

// For operations that return nothing on success.
struct Success
{};
using Status = Expected<Success>;

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_ERROR_H
