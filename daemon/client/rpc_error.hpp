// JSON-RPC errors as cmmd raises them: the spec's standard codes and cmmd's application codes
// (docs/api.md), each carrying the data a client needs to act on it (which field, which job).
#pragma once

#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "hal/description/json_fields.hpp"

namespace cmm::daemon {

namespace rpc_code {
inline constexpr int parse_error = -32700;
inline constexpr int invalid_request = -32600;
inline constexpr int method_not_found = -32601;
inline constexpr int invalid_params = -32602;
inline constexpr int internal_error = -32603;
inline constexpr int unauthorized = -32000;
inline constexpr int auth_failed = -32001;
inline constexpr int request_too_large = -32002;
inline constexpr int too_many_pending = -32003;
inline constexpr int too_many_connections = -32004;
inline constexpr int batch_too_large = -32005;
inline constexpr int server_busy = -32006;
inline constexpr int not_found = -32010;
inline constexpr int invalid_state = -32011;
inline constexpr int machine_busy = -32012;
inline constexpr int machine_fault = -32013;
inline constexpr int model_error = -32014;
inline constexpr int upload_error = -32015;
inline constexpr int planning_error = -32016;
inline constexpr int registration_error = -32017;
inline constexpr int shutting_down = -32020;
inline constexpr int storage_full = -32021;
}  // namespace rpc_code

// Thrown by a method handler (or the transport) and sent as the response's "error" member.
class RpcError : public std::runtime_error {
 public:
  RpcError(int code, const std::string& message, nlohmann::json data = nullptr)
      : std::runtime_error(message), code_(code), data_(std::move(data)) {}
  int code() const { return code_; }
  const nlohmann::json& data() const { return data_; }

 private:
  int code_;
  nlohmann::json data_;
};

// −32602 for the member at JSON Pointer `path` of a request's params ("" for params itself): the
// message names the member, the data carries its path for a client to point at the field.
[[noreturn]] void throw_invalid_param(const std::string& path, const std::string& message);
// −32602 for params the field checker refused: data.path is the first bad field's pointer, and
// data.problems lists every one ({"path", "message"}).
RpcError invalid_params(const description::FieldError& refused);

// Who a connection is: each method needs at least one of these (docs/api.md, Access).
enum class Role { none, observer, operator_ };
const char* to_string(Role role);
Role role_from_string(const std::string& text);  // throws std::invalid_argument naming the text

}  // namespace cmm::daemon
