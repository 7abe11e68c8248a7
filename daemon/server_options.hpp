// cmmd.json's "server" block: where RpcServer listens and the limits of its connections, which the
// dashboard's WebServer shares; in a header of its own, free of Asio (Beast's Boost.Asio and
// standalone Asio do not go in one translation unit).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "daemon/request_gate.hpp"
#include "daemon/token_book.hpp"
#include "daemon/worker_counts.hpp"

namespace cmm::daemon {

struct ServerOptions {
  std::string tcp_bind = "127.0.0.1";       // an address or a host name
  int tcp_port = 7620;                       // 0: ephemeral (see RpcServer::tcp_port)
  bool tcp_enabled = true;
  std::string unix_path;                     // empty: no Unix socket
  unsigned unix_mode = 0660;
  std::size_t max_request_bytes = 4u << 20;  // one line, without its newline
  std::size_t max_batch_entries = 128;       // requests in one batch; more: one batch_too_large error
  int max_connections = 256;                 // TCP connections; the dashboard's are counted apart
  // Of those, not authenticated by a token (the dashboard's: plain HTTP too): past this, or at
  // max_connections, the oldest of them is closed to make room; an authenticated one never is.
  int max_unauthenticated_connections = 64;
  int max_unix_connections = 64;             // Unix socket connections, counted apart: cmmctl stop always gets in
  int max_pending_requests = 64;             // slow requests running or queued, per connection
  // A partial line then silence this long: closed. A TCP connection that has not subscribed is
  // also closed when it sends no complete line for this long while it waits for no reply.
  double idle_timeout_s = 30;
  double auth_timeout_s = 10;                // a TCP connection (a WebSocket of role none) not authenticated by then is closed
  double auth_guesses_per_s = 5, auth_guess_burst = 20;  // how fast wrong tokens may come (AuthThrottle)
  std::vector<AccessToken> tokens;           // empty: the station token (station_token.hpp), and only loopback binds
  WorkerCounts workers;                      // the threads of the slow methods
  std::size_t max_unsent_bytes = 64u << 20;  // a connection further behind in reading than this is dropped
  std::size_t max_total_unsent_bytes = 256u << 20;  // the same for all connections together
  std::vector<std::string> topics = {"job", "machine"};  // what server.subscribe accepts
  bool operator==(const ServerOptions&) const = default;
};

// The request gate's share of the block, the same for TCP, the Unix socket and the dashboard.
inline GateLimits gate_limits(const ServerOptions& s) {
  return {.max_request_bytes = s.max_request_bytes,
          .max_batch_entries = s.max_batch_entries,
          .max_pending_requests = static_cast<std::size_t>(s.max_pending_requests > 0 ? s.max_pending_requests : 0)};
}

}  // namespace cmm::daemon
