// The token bucket that throttles one source's wrong tokens.
#include "daemon/auth_throttle.hpp"

#include <algorithm>

namespace cmm::daemon {

AuthThrottle::AuthThrottle(double per_second, double burst)
    : per_second_(per_second), burst_(burst), allowance_(burst), last_(Clock::now()) {}

void AuthThrottle::refill(Clock::time_point now) {
  const double elapsed = std::chrono::duration<double>(now - last_).count();
  if (elapsed > 0) allowance_ = std::min(burst_, allowance_ + elapsed * per_second_);
  last_ = std::max(last_, now);
}

bool AuthThrottle::allow(Clock::time_point now) {
  refill(now);
  return allowance_ >= 1;
}

void AuthThrottle::record_failure(Clock::time_point now) {
  refill(now);
  allowance_ = std::max(0.0, allowance_ - 1);
}

bool AuthThrottle::full(Clock::time_point now) const {
  const double elapsed = std::chrono::duration<double>(now - last_).count();
  return allowance_ + std::max(0.0, elapsed) * per_second_ >= burst_;
}

double AuthThrottle::retry_after_s() const { return std::max(0.0, (1 - allowance_) / per_second_); }

}  // namespace cmm::daemon
