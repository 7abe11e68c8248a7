// An empty folder of the test's own under GoogleTest's temp dir, for the tests that write real
// files (journals, job folders, models); the pid keeps parallel test runs apart.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace cmm::daemon {

inline std::filesystem::path fresh_folder(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / ("cmmd-" + name + "-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace cmm::daemon
