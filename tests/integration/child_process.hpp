// A real program started by a test (cmm-sim, later cmmd): its stdout piped for the ready line,
// stopped with SIGTERM (SIGKILL if it lingers) when the test is done with it.
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace cmm::testing {

class ChildProcess {
 public:
  // with_stderr: its stderr (a daemon's log) comes down the same pipe, for a test that reads the
  // log; otherwise stderr stays the test's own, and shows in ctest's output when the test fails.
  explicit ChildProcess(const std::vector<std::string>& argv, bool with_stderr = false);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // The next line of its stdout; throws std::runtime_error on EOF or after timeout_s.
  std::string read_line(double timeout_s);
  void signal(int sig);
  int wait();  // its exit status (128 + signal when killed)
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  std::string buffer_;
  bool reaped_ = false;
  int status_ = 0;
};

}  // namespace cmm::testing
