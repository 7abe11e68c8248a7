// The station's operator token: made once, kept in <state_dir>/operator.token (mode 0640, so local
// tools of cmmd's group can read it) and reused at every start, so a dashboard tab or a script keeps
// its access across a restart of cmmd; replaced only by server.rotate_token (cmmctl rotate-token).
#pragma once

#include <filesystem>
#include <functional>
#include <mutex>
#include <string>

#include "daemon/client/json_rpc.hpp"
#include "daemon/token_book.hpp"

namespace cmm::daemon {

// 32 random bytes from the kernel, as 64 hex digits.
std::string random_token();

class StationToken {
 public:
  StationToken(TokenBook& tokens, std::filesystem::path file);

  // When `tokens` has none configured: the token in the file if it holds one, else a new one
  // written there; either is given to `tokens` and returned. Otherwise removes the file (operators
  // then use cmmd.json's tokens) and returns "". Throws std::runtime_error naming the file when it
  // cannot be read or written.
  std::string set_up();
  // A new token in the file and in `tokens`, the old one refused from now on (connections it
  // authenticated keep their role until they close); throws like set_up, and std::logic_error when
  // there is no station token (cmmd.json configured tokens at start).
  std::string rotate();
  std::string current() const;  // "" when there is none

 private:
  TokenBook& tokens_;
  std::filesystem::path file_;
  mutable std::mutex mutex_;
  std::string token_;
};

// server.rotate_token (operator) → {"token"}; −32011 when there is no station token.
// `on_rotated` learns the new token (the dashboard's URL changes with it).
void add_station_token_method(RpcDispatcher& dispatcher, StationToken& token,
                              std::function<void(const std::string&)> on_rotated);

}  // namespace cmm::daemon
