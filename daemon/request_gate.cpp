// RequestGate: the limits and the dispatch every transport shares.
#include "daemon/request_gate.hpp"

#include <spdlog/spdlog.h>

#include <cctype>

namespace cmm::daemon {

namespace {

bool is_blank(std::string_view text) { return text.find_first_not_of(" \t\r\n") == std::string_view::npos; }

bool is_token_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 || std::string_view("!#$%&'*+-.^_`|~").find(c) != std::string_view::npos;
}

}  // namespace

bool looks_like_http(std::string_view line) {
  const std::size_t first = line.find_first_not_of(" \t");
  if (first == std::string_view::npos || std::isalpha(static_cast<unsigned char>(line[first])) == 0) return false;
  // The longest method or header name a browser sends fits: a line is never scanned whole, so a
  // megabyte of letters trickled in costs nothing per read.
  line = line.substr(first, 64);
  // A request line: METHOD SP target SP HTTP/x (RFC 9112 §3); a method is upper case by custom.
  std::size_t i = 0;
  while (i < line.size() && std::isupper(static_cast<unsigned char>(line[i])) != 0) ++i;
  if (i > 0 && i < line.size() && line[i] == ' ') return true;
  // A header field: token ":" (RFC 9110 §5.1).
  i = 0;
  while (i < line.size() && is_token_char(line[i])) ++i;
  return i > 0 && i < line.size() && line[i] == ':';
}

RequestGate::RequestGate(const RpcDispatcher& dispatcher, GateLimits limits, Framing framing)
    : dispatcher_(dispatcher), limits_(limits), framing_(framing) {}

nlohmann::json RequestGate::too_large(std::size_t bytes) const {
  return error_response(nullptr, RpcError(rpc_code::request_too_large,
                                          "request of " + std::to_string(bytes) + " bytes is over max_request_bytes (" +
                                              std::to_string(limits_.max_request_bytes) + ")",
                                          {{"max_request_bytes", limits_.max_request_bytes}}));
}

std::optional<std::string> RequestGate::refuse_partial(std::string_view partial, const RpcContext& ctx) const {
  if (framing_ != Framing::lines) return std::nullopt;
  partial = partial.substr(0, 64);  // the rules read a line's start only: never a scan per read of a long line
  if (looks_like_http(partial)) return "a line that looks like HTTP (this port speaks JSON-RPC lines only)";
  const std::size_t first = partial.find_first_not_of(" \t\r");
  if (!ctx.authenticated() && first != std::string_view::npos && partial[first] != '{' && partial[first] != '[')
    return "a line that is not a JSON-RPC object or batch before server.auth";
  return std::nullopt;
}

GateDecision RequestGate::admit(std::string_view text, RpcContext& ctx, std::size_t pending,
                                const AdmitWork& admit_work) const {
  GateDecision d;
  if (text.size() > limits_.max_request_bytes) {
    d.kind = GateDecision::Kind::close;
    d.answer = too_large(text.size());
    d.reason = "a request over max_request_bytes";
    return d;
  }
  if (is_blank(text)) return d;
  if (std::optional<std::string> refused = refuse_partial(text, ctx)) {
    d.kind = GateDecision::Kind::close;
    d.reason = std::move(*refused);
    return d;
  }
  nlohmann::json message;
  try {
    message = parse_message(text, {.max_depth = 128, .max_batch_entries = limits_.max_batch_entries});
  } catch (const RpcError& e) {
    spdlog::debug("connection {}: {}", ctx.connection_id(), e.what());
    d.kind = GateDecision::Kind::answer;
    d.answer = error_response(nullptr, e);
    return d;
  }
  const Work work = dispatcher_.work_of(message, ctx.role());
  if (work == Work::quick) {
    d.answer = dispatcher_.handle(message, ctx);
    d.kind = d.answer ? GateDecision::Kind::answer : GateDecision::Kind::nothing;
    return d;
  }
  const std::size_t count = message_size(message);
  if (pending + count > limits_.max_pending_requests) {
    spdlog::debug("connection {}: over max_pending_requests ({})", ctx.connection_id(), limits_.max_pending_requests);
    d.answer = refuse_message(message, RpcError(rpc_code::too_many_pending,
                                                "more than max_pending_requests (" +
                                                    std::to_string(limits_.max_pending_requests) +
                                                    ") requests pending from this client",
                                                {{"max_pending_requests", limits_.max_pending_requests}}));
    d.kind = d.answer ? GateDecision::Kind::answer : GateDecision::Kind::nothing;
    return d;
  }
  if (const std::optional<std::string> busy = admit_work(work, count, text.size())) {
    spdlog::info("connection {} ({}): {}", ctx.connection_id(), ctx.peer(), *busy);
    d.answer = refuse_message(message, RpcError(rpc_code::server_busy, *busy, {{"retry", true}}));
    d.kind = d.answer ? GateDecision::Kind::answer : GateDecision::Kind::nothing;
    return d;
  }
  d.kind = GateDecision::Kind::run;
  d.message = std::move(message);
  d.work = work;
  d.count = count;
  d.bytes = text.size();
  return d;
}

std::optional<std::string> RequestGate::run(const nlohmann::json& message, RpcContext& ctx) const {
  try {
    if (const auto response = dispatcher_.handle(message, ctx)) return to_wire(*response);
  } catch (const std::exception& e) {  // building the reply failed (out of memory): the request gets no answer
    spdlog::error("connection {}: a reply could not be made: {}", ctx.connection_id(), e.what());
  }
  return std::nullopt;
}

}  // namespace cmm::daemon
