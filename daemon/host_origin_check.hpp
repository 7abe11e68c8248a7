// Who may talk to the dashboard's server. Any page a browser on the station opens can reach
// 127.0.0.1: the Host header stops a foreign name resolving to us (DNS rebinding), the Origin header
// stops a foreign page from opening the JSON-RPC WebSocket (cross-site WebSocket hijacking).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace cmm::daemon {

struct HostRules {
  int port = 0;                              // the port the server listens on
  std::string bind;                          // server.tcp_bind
  std::vector<std::string> allowed_origins;  // http.allowed_origins
};

// A Host header names us when its port is ours (absent only for port 80) and its host is
// localhost, a loopback address (127.0.0.0/8, [::1]), the bind address, any IP address when the
// bind is 0.0.0.0 or :: (an address is never rebound); or when it is the host[:port] of an allowed
// origin, whatever the port (a reverse proxy's name).
bool host_allowed(std::string_view host, const HostRules& rules);

// An Origin header (the caller lets a request without one through: not a browser) is ours when
// it is http://<the request's Host> or one of the allowed origins; compared without case.
bool origin_allowed(std::string_view origin, std::string_view host, const HostRules& rules);

}  // namespace cmm::daemon
