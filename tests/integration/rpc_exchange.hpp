// Raw exchanges with a cmmd under test: a line and its reply, the error a call ends in, whether
// cmmd closed the connection; for the tests of the protocol and its limits.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "daemon/client/rpc_client.hpp"
#include "daemon/client/rpc_error.hpp"

namespace cmm::testing {

// The error a call ends in; a call that succeeds fails the test (and returns code 0).
daemon::RpcError error_of(daemon::RpcClient& client, const std::string& method,
                          const nlohmann::json& params = nlohmann::json::object(), double timeout_s = 30);
// The next line from cmmd, parsed; throws when none comes within timeout_s.
nlohmann::json next_reply(daemon::RpcClient& client, double timeout_s = 60);
// Sends `line` and a newline; the next line back, parsed.
nlohmann::json request_reply(daemon::RpcClient& client, const std::string& line, double timeout_s = 60);
// True once cmmd has closed the connection, false when it is still open after timeout_s. Whatever
// cmmd still sends before closing is skipped.
bool closed_by_cmmd(daemon::RpcClient& client, double timeout_s);
// [{"token", "role": "observer"}, {"token", "role": "operator"}] for cmmd.json's server.tokens.
nlohmann::json observer_and_operator_tokens(const std::string& observer, const std::string& operator_token);

}  // namespace cmm::testing
