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

Expected<std::string> readFile(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return Error(ErrorCode::kIoError, "cannot open " + path + ": " + std::strerror(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad())
    return Error(ErrorCode::kIoError, "cannot read " + path);
  return ss.str();
}

}  // namespace insitu_calibration
