// The JSON-RPC error codes' helpers and the connection roles' names.
#include "daemon/client/rpc_error.hpp"

namespace cmm::daemon {

const char* to_string(Role role) {
  switch (role) {
    case Role::none: return "none";
    case Role::observer: return "observer";
    case Role::operator_: return "operator";
  }
  return "?";
}

void throw_invalid_param(const std::string& path, const std::string& message) {
  throw RpcError(rpc_code::invalid_params, (path.empty() ? "params" : path) + ": " + message, {{"path", path}});
}

RpcError invalid_params(const description::FieldError& refused) {
  nlohmann::json problems = nlohmann::json::array();
  for (const description::FieldProblem& p : refused.problems()) problems.push_back({{"path", p.pointer}, {"message", p.message}});
  return RpcError(rpc_code::invalid_params, refused.what(), {{"path", refused.pointer()}, {"problems", problems}});
}

Role role_from_string(const std::string& text) {
  if (text == "none") return Role::none;
  if (text == "observer") return Role::observer;
  if (text == "operator") return Role::operator_;
  throw std::invalid_argument("unknown role \"" + text + "\" (expected observer or operator)");
}

}  // namespace cmm::daemon
