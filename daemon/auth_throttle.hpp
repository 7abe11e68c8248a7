// How fast one source's tokens may fail: each wrong token takes one from an allowance of `burst`
// that refills at `per_second`; while it is used up, the source's wrong tokens are answered as
// throttled and the log says so once, not once per guess (TokenBook).
#pragma once

#include <chrono>

namespace cmm::daemon {

class AuthThrottle {
 public:
  using Clock = std::chrono::steady_clock;

  explicit AuthThrottle(double per_second = 5, double burst = 20);

  // Whether a token may be compared now.
  bool allow(Clock::time_point now = Clock::now());
  void record_failure(Clock::time_point now = Clock::now());
  // Until the next guess is allowed, after allow() said no.
  double retry_after_s() const;
  // Whether the allowance is whole again (as of the last call): such a source can be forgotten.
  bool full(Clock::time_point now = Clock::now()) const;

 private:
  void refill(Clock::time_point now);

  double per_second_, burst_, allowance_;
  Clock::time_point last_;
};

}  // namespace cmm::daemon
