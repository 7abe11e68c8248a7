// POSIX calls behind write_atomically: open(O_EXCL) a sibling temp file, write, fsync, rename.
#include "daemon/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <string>

#include "geometry/file_error.hpp"

namespace cmm::daemon {

namespace {
[[noreturn]] void fail(const std::filesystem::path& file, const std::string& step, int error) {
  throw geometry::FileError::system(file, step, error);
}
}  // namespace

void sync_folder(const std::filesystem::path& folder) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) fail(folder, "cannot open the folder to sync it", errno);
  const int rc = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  if (rc != 0) fail(folder, "fsync of the folder", error);
}

void write_atomically(const std::filesystem::path& file, std::string_view content) {
  const std::filesystem::path folder = file.has_parent_path() ? file.parent_path() : ".";
  const std::filesystem::path temp = folder / ("." + file.filename().string() + ".tmp-" + std::to_string(::getpid()));
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail(file, "cannot create the temp file " + temp.string(), errno);
  // Whatever failed, the temp file goes: a full disk gets its space back and no half file stays.
  auto abandon = [&](const std::string& step, int error) {
    ::close(fd);
    ::unlink(temp.c_str());
    fail(file, step, error);
  };
  for (std::size_t done = 0; done < content.size();) {
    const ssize_t n = ::write(fd, content.data() + done, content.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) abandon("write", n < 0 ? errno : EIO);
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) abandon("fsync", errno);
  if (::close(fd) != 0) {
    const int error = errno;
    ::unlink(temp.c_str());
    fail(file, "close", error);
  }
  if (::rename(temp.c_str(), file.c_str()) != 0) {
    const int error = errno;
    ::unlink(temp.c_str());
    fail(file, "rename of " + temp.string(), error);
  }
  sync_folder(folder);
}

}  // namespace cmm::daemon
