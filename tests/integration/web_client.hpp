// The browser's side of cmmd's dashboard for the tests: HTTP requests with the headers a test
// chooses (a foreign Host or Origin) and a JSON-RPC WebSocket client, on Boost.Beast; every wait
// has a deadline.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "daemon/client/rpc_error.hpp"

namespace cmm::testing {

using Headers = std::map<std::string, std::string>;

struct HttpReply {
  int status = 0;
  Headers headers;  // names in lower case
  std::string body;
  std::string header(const std::string& lower_case_name) const;  // "" when absent
};

// One request to 127.0.0.1:port; Host is 127.0.0.1:port unless `headers` names one.
HttpReply http_request(int port, const std::string& method, const std::string& target, const Headers& headers = {});

// The server answered the upgrade with this HTTP status instead of 101.
struct WebSocketRefused : std::runtime_error {
  WebSocketRefused(int status, const std::string& body);
  int status;
};

class WebSocketClient {
 public:
  // Opens ws://127.0.0.1:port/rpc; Host is 127.0.0.1:port unless `headers` names one, and an
  // Origin is sent only when given. Throws WebSocketRefused when the upgrade is declined.
  explicit WebSocketClient(int port, const Headers& headers = {});
  ~WebSocketClient();
  WebSocketClient(const WebSocketClient&) = delete;
  WebSocketClient& operator=(const WebSocketClient&) = delete;

  // Sends one text message; false when the connection would not take it (cmmd closed it).
  bool send_text(const std::string& text, double timeout_s = 30);
  // The next message, parsed; nullopt once the connection is closed (close_code() tells why).
  // Throws std::runtime_error after timeout_s.
  std::optional<nlohmann::json> receive(double timeout_s = 30);
  int close_code() const;  // the code of cmmd's close frame; 0 for none

  // A request and its reply's result; notifications that come before it are kept for
  // wait_notification. Throws daemon::RpcError for an error reply.
  nlohmann::json call(const std::string& method, const nlohmann::json& params = nlohmann::json::object(),
                      double timeout_s = 60);
  // The error a call ends in; a call that succeeds throws std::runtime_error.
  daemon::RpcError error_of(const std::string& method, const nlohmann::json& params = nlohmann::json::object());
  // The next notification that `match` accepts (as {"method", "params"}); the others are dropped.
  nlohmann::json wait_notification(const std::string& what, const std::function<bool(const nlohmann::json&)>& match,
                                   double timeout_s);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cmm::testing
