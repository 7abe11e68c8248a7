// What other threads ask of a running job (job.pause, job.cancel, cmmd stopping, machine.stop): read
// by the runner between steps, while a stop() makes the motion in progress end at once.
#pragma once

#include <atomic>

namespace cmm::daemon {

struct JobControl {
  std::atomic<bool> pause{false};          // job.pause: hold after the current touch
  std::atomic<bool> cancel{false};         // job.cancel
  std::atomic<bool> shutdown{false};       // cmmd stopping: the job becomes interrupted
  std::atomic<bool> operator_stop{false};  // machine.stop or machine.abort during the job
  void clear() { pause = cancel = shutdown = operator_stop = false; }
};

}  // namespace cmm::daemon
