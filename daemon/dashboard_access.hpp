// How the operator gets into the dashboard: without tokens in cmmd.json, the URL's fragment carries
// the station's operator token (station_token.hpp); server.dashboard hands that URL to an operator
// (cmmctl dashboard).
#pragma once

#include <mutex>
#include <optional>
#include <string>

#include "daemon/client/json_rpc.hpp"

namespace cmm::daemon {

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
