// The tokens server.auth accepts on every transport (TCP, the Unix socket, the dashboard's WebSocket
// and its report links, MQTT): cmmd.json's, which SIGHUP replaces, and the station's operator token
// that cmmd keeps in its state folder (station_token.hpp).
#pragma once

#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "daemon/auth_throttle.hpp"
#include "daemon/client/rpc_error.hpp"

namespace cmm::daemon {

class RpcContext;

struct AccessToken {
  std::string token;
  Role role = Role::observer;
  bool operator==(const AccessToken&) const = default;
};

// What a guess got: the role its token grants, or nothing; `throttled` when the guess was wrong and
// its source has failed too often lately, with the time until its allowance is back.
struct TokenCheck {
  std::optional<Role> role;
  bool throttled = false;
  double retry_after_s = 0;
};

// Thread-safe: the io threads of both servers, a worker running a batch and the MQTT threads may
// check at once.
class TokenBook {
 public:
  TokenBook(std::vector<AccessToken> configured, double guesses_per_s, double guess_burst);

  // cmmd.json's tokens (SIGHUP); roles already granted stay with their connections.
  void set_configured(std::vector<AccessToken> tokens);
  // Whether cmmd.json names any token: without, the dashboard's WebSocket starts as observer.
  bool any_configured() const;
  // The station's own operator token (replaced when it is rotated): accepted like a configured
  // one, but it does not count as configured, so the rules above stay as cmmd.json has them.
  void set_station_token(std::string token);

  // Compares `guess` with every token in constant time, first: a right token is never refused,
  // whatever anyone else sent. Only a wrong one counts, against its `source` alone (a connection,
  // a broker user), so one client's guessing never locks another out.
  TokenCheck check(const std::string& guess, const std::string& source);

 private:
  mutable std::mutex mutex_;
  std::vector<AccessToken> configured_;
  std::optional<AccessToken> station_;
  double guesses_per_s_, guess_burst_;
  struct Source {
    AuthThrottle throttle;
    bool refusing = false;  // its throttling is logged once, not once per guess
    AuthThrottle::Clock::time_point last{};  // its latest wrong token
  };
  std::map<std::string, Source> sources_;  // bounded: full ones, then the longest quiet, are forgotten first
};

// Whose wrong tokens a peer's count as: its address without the port ("tcp://127.0.0.1" for
// "tcp://127.0.0.1:50412", "ws://[::1]"), so reconnecting starts no new allowance; a broker user
// ("mqtt:ops") as it is.
std::string auth_source(const std::string& peer);

// server.auth's rule for every transport: the token's role raises ctx's (never lowers it) and marks
// it authenticated; a wrong token throws −32001 (with data.retry_after_s when its source is
// throttled), and the context is asked to close after three wrong tokens or once throttled.
Role authenticate(TokenBook& tokens, const std::string& token, RpcContext& ctx, const std::string& source);

}  // namespace cmm::daemon
