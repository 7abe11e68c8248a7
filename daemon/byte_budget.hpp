// A server-wide allowance of bytes, taken and given back from any thread: what all connections'
// unsent replies, or all requests waiting for the workers, may hold of cmmd's memory together.
#pragma once

#include <atomic>
#include <cstddef>

namespace cmm::daemon {

class ByteBudget {
 public:
  explicit ByteBudget(std::size_t max_bytes) : max_bytes_(max_bytes) {}
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
