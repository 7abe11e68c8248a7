// POSIX calls behind the durable writer: temp file or spare, write, fsync, rename, fsync of the folder.
#include "geometry/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <string>

#include "geometry/file_error.hpp"

namespace cmm::geometry {

namespace {

[[noreturn]] void fail(const std::filesystem::path& file, const std::string& step, int error) {
  throw FileError::system(file, step, error);
}

// Every byte of `content` at `offset`; false with errno set when a write fails.
bool write_all(int fd, std::string_view content, std::uint64_t offset) {
  for (std::size_t done = 0; done < content.size();) {
    const ssize_t n = ::pwrite(fd, content.data() + done, content.size() - done, static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = EIO;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

std::filesystem::path folder_of(const std::filesystem::path& file) {
  return file.has_parent_path() ? file.parent_path() : std::filesystem::path(".");
}

constexpr std::string_view kTempMarker = ".tmp-";

// Hidden, and per process: two processes writing the same file never share a temp.
std::filesystem::path temp_for(const std::filesystem::path& file) {
  std::string name = ".";  // appended piece by piece: GCC 12 -O3's false -Wrestrict (bug 105329)
  name += file.filename().string();
  name += kTempMarker;
  name += std::to_string(::getpid());
  return folder_of(file) / name;
}

// EPERM: the process exists, it is only another user's.
bool process_alive(int pid) { return ::kill(pid, 0) == 0 || errno == EPERM; }

}  // namespace

void sync_folder(const std::filesystem::path& folder) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) fail(folder, "cannot open the folder to sync it", errno);
  const int rc = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  if (rc != 0) fail(folder, "fsync of the folder", error);
}

void write_atomically(const std::filesystem::path& file, std::string_view content, std::optional<unsigned> mode) {
  const std::filesystem::path temp = temp_for(file);
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, mode.value_or(0644));
  if (fd < 0) fail(file, "cannot create the temp file " + temp.string(), errno);
  // Whatever failed, the temp file goes: a full disk gets its space back and no half file stays.
  auto abandon = [&](const std::string& step, int error) {
    ::close(fd);
    ::unlink(temp.c_str());
    fail(file, step, error);
  };
  if (mode && ::fchmod(fd, *mode) != 0) abandon("fchmod", errno);  // the umask may not narrow it either
  if (!write_all(fd, content, 0)) abandon("write", errno);
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
  sync_folder(folder_of(file));
}

bool allocate_spare(const std::filesystem::path& spare, std::size_t bytes) {
  const int fd = ::open(spare.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return false;
  const int rc = ::posix_fallocate(fd, 0, static_cast<off_t>(bytes));
  ::close(fd);
  if (rc != 0) ::unlink(spare.c_str());  // half a spare is no reserve: give its space back
  return rc == 0;
}

bool write_through_spare(const std::filesystem::path& file, const std::filesystem::path& spare,
                         std::string_view content, std::size_t spare_bytes) {
  if (content.size() > spare_bytes || !std::filesystem::exists(spare)) return false;
  const int fd = ::open(spare.c_str(), O_WRONLY | O_CLOEXEC);
  bool written = fd >= 0 && write_all(fd, content, 0);
  written = written && ::ftruncate(fd, static_cast<off_t>(content.size())) == 0 && ::fsync(fd) == 0;
  if (fd >= 0) written = ::close(fd) == 0 && written;
  if (written && ::rename(spare.c_str(), file.c_str()) == 0) {
    sync_folder(folder_of(file));
    return true;
  }
  ::unlink(spare.c_str());  // whatever it holds now is no record
  return false;
}

void write_chunk(const std::filesystem::path& file, std::uint64_t offset, std::string_view bytes) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) fail(file, "cannot open", errno);
  auto abandon = [&](const std::string& step, int error) {
    if (::ftruncate(fd, static_cast<off_t>(offset)) == 0) (void)::fsync(fd);
    ::close(fd);
    fail(file, step, error);
  };
  if (::ftruncate(fd, static_cast<off_t>(offset)) != 0) abandon("truncate", errno);
  if (!write_all(fd, bytes, offset)) abandon("write", errno);
  if (::fsync(fd) != 0) abandon("fsync", errno);
  ::close(fd);
}

std::optional<int> atomic_temp_writer(const std::filesystem::path& path) {
  const std::string name = path.filename().string();
  const std::size_t marker = name.rfind(kTempMarker);
  // "." and at least one character of the file's own name before the marker.
  if (name.empty() || name.front() != '.' || marker == std::string::npos || marker < 2) return std::nullopt;
  const char* digits = name.data() + marker + kTempMarker.size();
  const char* end = name.data() + name.size();
  int pid = 0;
  const auto [stop, ec] = std::from_chars(digits, end, pid);
  if (ec != std::errc() || stop != end || digits == end || *digits == '+' || pid <= 0) return std::nullopt;
  return pid;
}

TempSweep remove_stale_atomic_temps(const std::filesystem::path& root) {
  namespace fs = std::filesystem;
  TempSweep sweep;
  std::vector<fs::path> stale;
  std::error_code ec;
  fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec);
  for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    const std::optional<int> writer = atomic_temp_writer(it->path());
    std::error_code type_error;
    if (!writer || !it->is_regular_file(type_error)) continue;
    if (*writer == ::getpid() || !process_alive(*writer)) stale.push_back(it->path());
  }
  if (ec && ec != std::errc::no_such_file_or_directory)
    sweep.problems.push_back("cannot list all of " + root.string() + ": " + ec.message());
  for (const fs::path& temp : stale) {
    std::error_code removed;
    if (fs::remove(temp, removed)) ++sweep.removed;
    else if (removed) sweep.problems.push_back("cannot remove " + temp.string() + ": " + removed.message());
  }
  return sweep;
}

}  // namespace cmm::geometry
