// A test's own folder, on tmpfs where there is one: a job fsyncs its journal and touch-in-progress
// file at every touch, which on a disk costs more than the motion, and a SIGKILL loses nothing the
// page cache holds. Removed when the test passed, kept for a look when it failed.
#pragma once

#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

namespace cmm::testing {

struct ScratchFolder {
  // <tmpfs or temp>/<suite>_<name>_<pid>, empty.
  ScratchFolder(const std::string& suite, const std::string& name) {
    const bool shm = std::filesystem::is_directory("/dev/shm");
    path = (shm ? std::filesystem::path("/dev/shm") : std::filesystem::temp_directory_path()) /
           (suite + "_" + name + "_" + std::to_string(getpid()));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~ScratchFolder() {
    std::error_code ignored;
    if (!::testing::Test::HasFailure()) std::filesystem::remove_all(path, ignored);
  }
  ScratchFolder(const ScratchFolder&) = delete;
  ScratchFolder& operator=(const ScratchFolder&) = delete;

  std::filesystem::path path;
};

}  // namespace cmm::testing
