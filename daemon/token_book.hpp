// The tokens server.auth accepts on every transport (TCP, the Unix socket, the dashboard's WebSocket
// and its report links): cmmd.json's, which SIGHUP replaces, and the dashboard's, made at start.
#pragma once

#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "daemon/auth_throttle.hpp"
#include "daemon/client/rpc_error.hpp"

namespace cmm::daemon {

struct AccessToken {
  std::string token;
  Role role = Role::observer;
  bool operator==(const AccessToken&) const = default;
};

// What a guess got: the role its token grants, or nothing; `throttled` when it was not compared at
// all because wrong guesses came too fast lately (from anyone), with the time until one may.
struct TokenCheck {
  std::optional<Role> role;
  bool throttled = false;
  double retry_after_s = 0;
};

// Thread-safe: the io threads of both servers and a worker running a batch may check at once.
class TokenBook {
 public:
  TokenBook(std::vector<AccessToken> configured, double guesses_per_s, double guess_burst);

  // cmmd.json's tokens (SIGHUP); roles already granted stay with their connections.
  void set_configured(std::vector<AccessToken> tokens);
  // Whether cmmd.json names any token: without, TCP is operator and the dashboard starts observer.
  bool any_configured() const;
  // A token cmmd made itself (the dashboard's): accepted like a configured one, but it does not
  // count as configured, so the rules above stay as cmmd.json has them. Kept until cmmd stops.
  void add_generated(AccessToken token);

  // Compares `guess` with every token in constant time; a wrong guess counts against the throttle.
  TokenCheck check(const std::string& guess);

 private:
  mutable std::mutex mutex_;
  std::vector<AccessToken> configured_, generated_;
  AuthThrottle throttle_;
  bool refusing_ = false;  // the throttle's refusal is logged once, not once per guess
};

}  // namespace cmm::daemon
