// How the operator gets into the dashboard: without tokens in cmmd.json, cmmd makes an operator
// token at each start, keeps it in <state_dir>/dashboard.token (0600) and puts it in the URL's
// fragment; server.dashboard hands that URL to an operator (cmmctl dashboard).
#pragma once

#include <filesystem>
#include <mutex>
#include <optional>
#include <string>

#include "daemon/client/json_rpc.hpp"
#include "daemon/token_book.hpp"

namespace cmm::daemon {

// 32 random bytes from the kernel, as 64 hex digits.
std::string random_token();

// When `tokens` has none configured: a fresh operator token, written to `file` (mode 0600, replaced
// atomically) and added to `tokens`; returns it. Otherwise removes a stale `file` and returns "".
// Throws std::runtime_error naming the file when it cannot be written.
std::string set_up_dashboard_token(TokenBook& tokens, const std::filesystem::path& file);

// http://HOST:PORT/ with `#token=` when there is one; HOST is the bind address, 127.0.0.1 for a
// bind on every address, an IPv6 address in brackets.
std::string dashboard_url(const std::string& bind, int port, const std::string& token);

// The URL server.dashboard answers with: set once the server listens, read by any thread.
class DashboardLink {
 public:
  void set(std::string url);
  std::optional<std::string> url() const;

 private:
  mutable std::mutex mutex_;
  std::optional<std::string> url_;
};

// server.dashboard (operator) → {"url"}; −32011 while there is no dashboard (http.enabled false).
void add_dashboard_method(RpcDispatcher& dispatcher, const DashboardLink& link);

}  // namespace cmm::daemon
