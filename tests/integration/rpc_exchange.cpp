// Raw JSON-RPC lines to a real cmmd and their replies, for the tests that send what a client would not.
#include "rpc_exchange.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <stdexcept>

namespace cmm::testing {

daemon::RpcError error_of(daemon::RpcClient& client, const std::string& method, const nlohmann::json& params,
                          double timeout_s) {
  try {
    const nlohmann::json result = client.call(method, params, timeout_s);
    ADD_FAILURE() << method << " " << params.dump().substr(0, 200) << " succeeded: " << result.dump().substr(0, 200);
  } catch (const daemon::RpcError& e) {
    return e;
  }
  return daemon::RpcError(0, "no error");
}

nlohmann::json next_reply(daemon::RpcClient& client, double timeout_s) {
  const std::optional<std::string> line = client.read_line(timeout_s);
  if (!line) throw std::runtime_error("no reply within " + std::to_string(timeout_s) + " s");
  return nlohmann::json::parse(*line);
}

nlohmann::json request_reply(daemon::RpcClient& client, const std::string& line, double timeout_s) {
  client.send_raw(line + "\n");
  return next_reply(client, timeout_s);
}

bool closed_by_cmmd(daemon::RpcClient& client, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  try {
    for (;;) {
      const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
      if (left <= 0 || !client.read_line(left)) return false;
    }
  } catch (const daemon::RpcClientError&) {
    return true;
  }
}

nlohmann::json observer_and_operator_tokens(const std::string& observer, const std::string& operator_token) {
  return nlohmann::json::array(
      {{{"token", observer}, {"role", "observer"}}, {{"token", operator_token}, {"role", "operator"}}});
}

}  // namespace cmm::testing
