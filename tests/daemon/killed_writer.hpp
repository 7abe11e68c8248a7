// Crash tests: a forked child writes for ever and is killed with SIGKILL once the parent sees
// enough written, so the test can check what a daemon killed at that moment leaves behind.
#pragma once

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <thread>

#include <gtest/gtest.h>

namespace cmm::daemon {

// Runs `write_for_ever` in a child (it must not return), waits until `enough()` holds (at most
// 30 s), then kills the child and reaps it. Returns whether `enough()` was reached.
inline bool kill_writer_when(const std::function<void()>& write_for_ever, const std::function<bool()>& enough) {
  const pid_t child = fork();
  if (child < 0) {
    ADD_FAILURE() << "fork failed";
    return false;
  }
  if (child == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlives the test
    try {
      write_for_ever();
    } catch (...) {
    }
    std::_Exit(1);  // never back into the test runner's own code
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  bool reached = false;
  while (!(reached = enough()) && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  return reached;
}

}  // namespace cmm::daemon
