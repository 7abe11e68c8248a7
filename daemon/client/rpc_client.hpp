// A blocking JSON-RPC client of cmmd (cmmctl, the integration tests, the benchmark): one call at a
// time over tcp://HOST:PORT, unix:/PATH or a fleet's MQTT broker, with notifications queued while
// it waits.
#pragma once

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "daemon/client/rpc_error.hpp"
#include "daemon/client/station_link.hpp"

namespace cmm::daemon {

// The transport failed: the message names the endpoint and what happened.
class RpcClientError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Used from one thread at a time.
class RpcClient {
 public:
  // endpoint: "tcp://HOST:PORT" (HOST may be [v6]) or "unix:/PATH".
  static RpcClient connect(const std::string& endpoint, double timeout_s = 5);
  // A station through a fleet's MQTT broker (docs/fleet.md); the token goes with every request, so
  // server.auth is not needed (and answers with the token's role).
  static RpcClient connect_station(StationAddress address, double timeout_s = 5);
  RpcClient(RpcClient&&) noexcept;
  RpcClient& operator=(RpcClient&&) noexcept;
  ~RpcClient();

  // Returns the reply's "result"; throws RpcError with the reply's code, message and data, or
  // RpcClientError (closed, no reply within timeout_s, an unreadable reply).
  nlohmann::json call(const std::string& method, const nlohmann::json& params = nlohmann::json::object(),
                      double timeout_s = 30);
  // A JSON-RPC notification: no id, no reply.
  void notify(const std::string& method, const nlohmann::json& params = nlohmann::json::object());
  // The next server notification as {"method", "params"}, or nothing within timeout_s.
  std::optional<nlohmann::json> wait_notification(double timeout_s);

  // For protocol tests: bytes as they are, and the next line as it came (without its newline),
  // or nothing within timeout_s; throws RpcClientError once the server has closed.
  void send_raw(std::string_view bytes);
  std::optional<std::string> read_line(double timeout_s);

  const std::string& endpoint() const;
  void close();

 private:
  struct Connection;
  explicit RpcClient(std::unique_ptr<Connection> connection);
  std::unique_ptr<Connection> connection_;
};

}  // namespace cmm::daemon
