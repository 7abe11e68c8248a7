// JSON-RPC 2.0 messages on the wire: parsing a line (with the byte of any error), building replies,
// requests and notifications.
#include "daemon/client/json_rpc.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>

namespace cmm::daemon {

namespace {

using nlohmann::json;

bool usable_id(const json& request) {
  if (!request.is_object()) return false;
  const auto it = request.find("id");
  return it != request.end() && (it->is_string() || it->is_number() || it->is_null());
}

json result_response(const json& id, json result) {
  return {{"jsonrpc", "2.0"}, {"result", std::move(result)}, {"id", id}};
}

RpcError invalid_request(const std::string& why) { return RpcError(rpc_code::invalid_request, "invalid request: " + why); }

// What makes a request invalid (spec §4, §5.1), or "" when it is well formed.
std::string request_problem(const json& request) {
  if (!request.is_object()) return "a request must be a JSON object";
  if (request.contains("id") && !usable_id(request)) return "\"id\" must be a string, a number or null";
  const auto version = request.find("jsonrpc");
  if (version == request.end() || *version != "2.0") return "\"jsonrpc\" must be \"2.0\"";
  const auto method = request.find("method");
  if (method == request.end() || !method->is_string()) return "\"method\" must be a string";
  const auto params = request.find("params");
  if (params != request.end() && !params->is_object() && !params->is_array())
    return "\"params\" must be an object or an array";
  return {};
}

}  // namespace

std::uint64_t next_connection_id() {
  static std::atomic<std::uint64_t> next{1};
  return next++;
}

std::vector<std::string> RpcContext::subscribe(const std::vector<std::string>& topics) {
  std::lock_guard lock(topics_mutex_);
  topics_.insert(topics.begin(), topics.end());
  return {topics_.begin(), topics_.end()};
}

bool RpcContext::subscribed(const std::string& topic) const {
  std::lock_guard lock(topics_mutex_);
  return topics_.count(topic) != 0;
}

bool RpcContext::subscribed_any() const {
  std::lock_guard lock(topics_mutex_);
  return !topics_.empty();
}

void RpcDispatcher::add(std::string method, MethodSpec spec) {
  if (!spec.handler) throw std::logic_error("JSON-RPC method \"" + method + "\" registered without a handler");
  const auto [it, added] = methods_.emplace(method, std::move(spec));
  if (!added) throw std::logic_error("JSON-RPC method \"" + method + "\" registered twice");
}

std::vector<std::string> RpcDispatcher::methods() const {
  std::vector<std::string> names;
  for (const auto& [name, spec] : methods_) names.push_back(name);
  return names;
}

Work RpcDispatcher::work_of(const json& message, Role role) const {
  const auto work = [this, role](const json& request) {
    if (!request.is_object()) return Work::quick;
    const auto method = request.find("method");
    if (method == request.end() || !method->is_string()) return Work::quick;
    const auto it = methods_.find(method->get_ref<const std::string&>());
    // A single call above the caller's role is refused without running: at once, never queued.
    return it != methods_.end() && role >= it->second.role ? it->second.work : Work::quick;
  };
  if (!message.is_array()) return work(message);
  // A batch may raise its own role (server.auth first): its methods count whatever the role now.
  Work heaviest = Work::quick;
  for (const json& request : message) heaviest = std::max(heaviest, RpcDispatcher::work_of(request, Role::operator_));
  return heaviest;
}

json RpcDispatcher::handle_one(const json& request, RpcContext& ctx, bool& reply) const {
  json response = answer_one(request, ctx, reply);
  if (answered_ && reply) {
    const auto method = request.is_object() ? request.find("method") : request.end();
    answered_(method != request.end() && method->is_string() ? method->get<std::string>() : std::string(),
              response.contains("error"));
  }
  return response;
}

json RpcDispatcher::answer_one(const json& request, RpcContext& ctx, bool& reply) const {
  // An invalid request is answered even without an id (spec §7: [1,2,3] gets three errors).
  reply = true;
  const json id = usable_id(request) ? request["id"] : json(nullptr);
  if (const std::string problem = request_problem(request); !problem.empty())
    return error_response(id, invalid_request(problem));
  reply = request.contains("id");

  const auto& method = request["method"].get_ref<const std::string&>();
  const auto it = methods_.find(method);
  if (it == methods_.end())
    return error_response(id, RpcError(rpc_code::method_not_found, "method \"" + method + "\" not found", {{"method", method}}));
  const MethodSpec& spec = it->second;
  if (ctx.role() < spec.role)
    return error_response(id, RpcError(rpc_code::unauthorized,
                                       method + " needs role " + to_string(spec.role) + ", this connection has " +
                                           to_string(ctx.role()),
                                       {{"needed", to_string(spec.role)}}));
  const auto params = request.find("params");
  try {
    return result_response(id, spec.handler(params != request.end() ? *params : json::object(), ctx));
  } catch (const RpcError& e) {
    return error_response(id, e);
  } catch (const std::exception& e) {
    spdlog::warn("JSON-RPC {} from {} failed: {}", method, ctx.peer(), e.what());
    return error_response(id, RpcError(rpc_code::internal_error, e.what()));
  } catch (...) {
    spdlog::warn("JSON-RPC {} from {} failed with a non-standard exception", method, ctx.peer());
    return error_response(id, RpcError(rpc_code::internal_error, method + " failed"));
  }
}

std::optional<json> RpcDispatcher::handle(const json& message, RpcContext& ctx) const {
  bool reply = false;
  if (!message.is_array()) {
    json response = handle_one(message, ctx, reply);
    return reply ? std::optional<json>(std::move(response)) : std::nullopt;
  }
  if (message.empty()) return error_response(nullptr, invalid_request("an empty batch"));
  json responses = json::array();
  for (const json& request : message) {
    json response = handle_one(request, ctx, reply);
    if (reply) responses.push_back(std::move(response));
  }
  if (responses.empty()) return std::nullopt;
  return responses;
}

std::optional<std::string> RpcDispatcher::handle_line(std::string_view line, RpcContext& ctx) const {
  json message;
  try {
    message = parse_message(line);
  } catch (const RpcError& e) {
    return to_wire(error_response(nullptr, e));
  }
  const auto response = handle(message, ctx);
  if (!response) return std::nullopt;
  return to_wire(*response);
}

namespace {

// Where and why a text stops being JSON that a double can hold. json::parse reports a number beyond
// a double's range (1e400, a 5,000-digit integer) as out_of_range, without where it is; the SAX
// pass over the same text reports both, for −32700's data.byte.
class ProblemLocator : public json::json_sax_t {
 public:
  std::size_t byte = 0;
  std::string what = "not JSON";
  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool start_object(std::size_t) override { return true; }
  bool key(string_t&) override { return true; }
  bool end_object() override { return true; }
  bool start_array(std::size_t) override { return true; }
  bool end_array() override { return true; }
  bool parse_error(std::size_t position, const std::string&, const nlohmann::detail::exception& e) override {
    byte = position;
    what = e.what();
    if (what.size() > 200) what = what.substr(0, 200) + "…";  // a 5,000-digit number is not quoted back whole
    return false;
  }
};

// nlohmann's "[json.exception.parse_error.101] " prefix is for programmers, not for clients.
std::string without_exception_prefix(std::string what) {
  if (const auto end = what.find("] "); what.rfind("[json.exception", 0) == 0 && end != std::string::npos)
    what.erase(0, end + 2);
  return what;
}

}  // namespace

json parse_message(std::string_view line, const ParseLimits& limits) {
  int depth = 0;
  bool in_string = false, escaped = false;
  const std::size_t first = line.find_first_not_of(" \t\r\n");
  const bool batch = first != std::string_view::npos && line[first] == '[';
  std::size_t entries = 1;  // of a batch: its commas at depth 1, plus one
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > limits.max_depth)
        throw RpcError(rpc_code::parse_error, "parse error: nesting deeper than " + std::to_string(limits.max_depth),
                       {{"byte", i + 1}});
    } else if (c == ']' || c == '}') {
      --depth;
    } else if (c == ',' && batch && depth == 1 && ++entries > limits.max_batch_entries) {
      throw RpcError(rpc_code::batch_too_large,
                     "a batch of more than max_batch_entries (" + std::to_string(limits.max_batch_entries) + ") requests",
                     {{"max_batch_entries", limits.max_batch_entries}});
    }
  }
  try {
    return json::parse(line);
  } catch (const json::parse_error& e) {
    throw RpcError(rpc_code::parse_error, without_exception_prefix(e.what()), {{"byte", e.byte}});
  } catch (const json::exception&) {
    ProblemLocator problem;
    json::sax_parse(line, &problem);
    throw RpcError(rpc_code::parse_error, "parse error at byte " + std::to_string(problem.byte) + ": " +
                                              without_exception_prefix(problem.what),
                   {{"byte", problem.byte}});
  }
}

json error_response(const json& id, const RpcError& error) {
  json body = {{"code", error.code()}, {"message", error.what()}};
  if (!error.data().is_null()) body["data"] = error.data();
  return {{"jsonrpc", "2.0"}, {"error", std::move(body)}, {"id", id}};
}

std::optional<json> refuse_message(const json& message, const RpcError& error) {
  if (!message.is_array()) {
    if (!usable_id(message)) return std::nullopt;
    return error_response(message["id"], error);
  }
  json responses = json::array();
  for (const json& request : message)
    if (usable_id(request)) responses.push_back(error_response(request["id"], error));
  if (responses.empty()) return std::nullopt;
  return responses;
}

std::size_t message_size(const json& message) { return message.is_array() ? std::max<std::size_t>(message.size(), 1) : 1; }

std::string to_wire(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }

}  // namespace cmm::daemon
