// A small tmpfs of a test's own, so that cmmd's writes meet a really full disk (ENOSPC): mounted on
// a folder (as root, as CI runs; a test skips without it), filled with one file at the moment the
// test chooses, and emptied again. tmpfs counts whole pages: every non-empty file holds at least one.
#pragma once

#include <fcntl.h>
#include <sys/mount.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace cmm::test {

class SmallTmpfs {
 public:
  SmallTmpfs(std::filesystem::path dir, std::uint64_t bytes) : dir_(std::move(dir)) {
    std::filesystem::create_directories(dir_);
    const std::string options = "size=" + std::to_string(bytes) + ",mode=0755";
    if (::mount("tmpfs", dir_.c_str(), "tmpfs", 0, options.c_str()) != 0)
      error_ = "cannot mount a tmpfs on " + dir_.string() + ": " + std::strerror(errno) + " (the test needs root)";
    else
      mounted_ = true;
  }
  ~SmallTmpfs() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);  // lazily: a child may still hold a file open
  }
  SmallTmpfs(const SmallTmpfs&) = delete;
  SmallTmpfs& operator=(const SmallTmpfs&) = delete;

  bool mounted() const { return mounted_; }
  const std::string& error() const { return error_; }
  const std::filesystem::path& dir() const { return dir_; }
  std::filesystem::path filler() const { return dir_ / "filler"; }

  std::uint64_t free_bytes() const {
    struct statvfs s {};
    if (::statvfs(dir_.c_str(), &s) != 0) throw std::runtime_error("statvfs " + dir_.string() + ": " + std::strerror(errno));
    return static_cast<std::uint64_t>(s.f_bavail) * s.f_frsize;
  }

  // Writes the filler until not one byte more fits, then gives `leave_bytes` back (whole pages).
  void fill(std::uint64_t leave_bytes = 0) {
    const int fd = ::open(filler().c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd < 0) throw std::runtime_error("cannot create " + filler().string() + ": " + std::strerror(errno));
    const std::vector<char> block(1 << 20, 'x');
    for (const std::size_t size : {std::size_t{1} << 20, std::size_t{4096}, std::size_t{1}})
      while (::write(fd, block.data(), size) > 0) {
      }
    if (errno != ENOSPC) {
      ::close(fd);
      throw std::runtime_error("filling " + dir_.string() + ": " + std::strerror(errno));
    }
    const off_t size = ::lseek(fd, 0, SEEK_END);
    if (leave_bytes > 0 && ::ftruncate(fd, size > static_cast<off_t>(leave_bytes) ? size - static_cast<off_t>(leave_bytes) : 0) != 0) {
      ::close(fd);
      throw std::runtime_error("cutting " + filler().string() + ": " + std::strerror(errno));
    }
    ::close(fd);
  }
  void unfill() { std::filesystem::remove(filler()); }

 private:
  std::filesystem::path dir_;
  bool mounted_ = false;
  std::string error_;
};

}  // namespace cmm::test
