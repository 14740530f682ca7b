#include "insitu_calibration/io/atomic_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace insitu_calibration
{
Status writeFileAtomically(const std::string& path, const std::string& content)
{
  namespace fs = std::filesystem;
  const fs::path target(path);
  std::error_code ec;
  if (path.empty() || !target.has_filename())
    return Error(ErrorCode::kInvalidInput, "cannot write to '" + path + "': give a file name");
  if (fs::is_directory(target, ec))
    return Error(ErrorCode::kInvalidInput, "cannot write to " + path + ": it is a directory; give a file name");
  if (target.has_parent_path())
  {
    fs::create_directories(target.parent_path(), ec);
    if (ec)
      return Error(ErrorCode::kIoError,
                   "cannot create directory " + target.parent_path().string() + ": " + ec.message());
  }
  std::string temp = path + ".tmp.XXXXXX";
  const int fd = mkstemp(temp.data());
  if (fd < 0)
    return Error(ErrorCode::kIoError, "cannot create a temporary file next to " + path + ": " + std::strerror(errno));
  size_t written = 0;
  while (written < content.size())
  {
    const ssize_t n = ::write(fd, content.data() + written, content.size() - written);
    if (n < 0 && errno == EINTR)
      continue;
    if (n <= 0)
    {
      const std::string reason = std::strerror(errno);
      ::close(fd);
      ::unlink(temp.c_str());
      return Error(ErrorCode::kIoError, "cannot write " + temp + ": " + reason);
    }
    written += static_cast<size_t>(n);
  }
  // Readable like an ordinary file (mkstemp creates it 0600).
  ::fchmod(fd, 0644);
  if (::fsync(fd) != 0 || ::close(fd) != 0)
  {
    const std::string reason = std::strerror(errno);
    ::unlink(temp.c_str());
    return Error(ErrorCode::kIoError, "cannot flush " + temp + ": " + reason);
  }
  if (std::rename(temp.c_str(), path.c_str()) != 0)
  {
    const std::string reason = std::strerror(errno);
    ::unlink(temp.c_str());
    return Error(ErrorCode::kIoError, "cannot rename " + temp + " to " + path + ": " + reason);
  }
  return Success{};
}

Expected<std::string> readFile(const std::string& path, size_t max_bytes)
{
  std::error_code ec;
  if (path.empty())
    return Error(ErrorCode::kIoError, "cannot open '': no file name given");
  if (std::filesystem::is_directory(path, ec))
    return Error(ErrorCode::kIoError, "cannot read " + path + ": it is a directory, not a file");
  if (const auto size = std::filesystem::file_size(path, ec); !ec && size > max_bytes)
    return Error(ErrorCode::kInvalidInput, "cannot read " + path + ": " + std::to_string(size) +
                                               " bytes, more than the " + std::to_string(max_bytes) + " allowed");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return Error(ErrorCode::kIoError, "cannot open " + path + ": " + std::strerror(errno));
  // Read in chunks up to the limit: a FIFO or /dev/zero has no size to check beforehand.
  std::string text;
  char chunk[65536];
  while (in.read(chunk, sizeof chunk) || in.gcount() > 0)
  {
    text.append(chunk, static_cast<size_t>(in.gcount()));
    if (text.size() > max_bytes)
      return Error(ErrorCode::kInvalidInput,
                   "cannot read " + path + ": more than the " + std::to_string(max_bytes) + " bytes allowed");
  }
  if (in.bad())
    return Error(ErrorCode::kIoError, "cannot read " + path);
  return text;
}

}  // namespace insitu_calibration
