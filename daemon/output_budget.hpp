// The bytes waiting in every connection's output queue together: a connection whose next line
// would go over the server-wide budget is dropped, so clients that never read cannot together
// hold more than this much of cmmd's memory.
#pragma once

#include <atomic>
#include <cstddef>

namespace cmm::daemon {

class OutputBudget {
 public:
  explicit OutputBudget(std::size_t max_bytes) : max_bytes_(max_bytes) {}
  // Takes `bytes` unless that would go over the budget; thread-safe.
  bool take(std::size_t bytes) {
    std::size_t used = used_.load();
    do {
      if (used + bytes > max_bytes_) return false;
    } while (!used_.compare_exchange_weak(used, used + bytes));
    return true;
  }
  void give(std::size_t bytes) { used_ -= bytes; }
  std::size_t used() const { return used_.load(); }

 private:
  const std::size_t max_bytes_;
  std::atomic<std::size_t> used_{0};
};

}  // namespace cmm::daemon
