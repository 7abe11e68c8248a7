// JSON-RPC 2.0 without I/O: a table of methods with the role each needs, and the spec's rules
// for requests, notifications, batches and errors, so the transport only moves lines.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/rpc_error.hpp"

namespace cmm::daemon {

// One connection as its handlers see it. The role and the topics may change while a slow method
// runs on a worker thread (server.auth on the io thread), so they are read and written atomically.
class RpcContext {
 public:
  RpcContext(std::uint64_t connection_id, std::string peer, Role role)
      : connection_id_(connection_id), peer_(std::move(peer)), role_(role) {}

  std::uint64_t connection_id() const { return connection_id_; }
  const std::string& peer() const { return peer_; }  // e.g. "tcp://127.0.0.1:50412", for logs
  Role role() const { return role_.load(); }
  void set_role(Role role) { role_.store(role); }

  // Adds to the connection's topics; returns all of them, sorted.
  std::vector<std::string> subscribe(const std::vector<std::string>& topics);
  bool subscribed(const std::string& topic) const;

 private:
  std::uint64_t connection_id_;
  std::string peer_;
  std::atomic<Role> role_;
  mutable std::mutex topics_mutex_;
  std::set<std::string> topics_;
};

// A handler returns the call's "result"; it throws RpcError for a JSON-RPC error, and any other
// std::exception becomes −32603 with its message.
using Handler = std::function<nlohmann::json(const nlohmann::json& params, RpcContext& ctx)>;

struct MethodSpec {
  Role role = Role::operator_;  // the least role that may call it
  bool slow = false;            // true: the transport runs it off the io thread (it may block)
  Handler handler;
};

class RpcDispatcher {
 public:
  // Register every method before a server starts serving; throws std::logic_error on a second
  // registration of one name or on an empty handler.
  void add(std::string method, MethodSpec spec);
  std::vector<std::string> methods() const;  // sorted

  // One message (a request, a notification or a batch) → its reply, or nothing when the spec
  // says no reply (a notification, a batch of notifications). `params` absent reads as {}.
  std::optional<nlohmann::json> handle(const nlohmann::json& message, RpcContext& ctx) const;
  // The same from and to wire text: a line that is not JSON is answered with −32700.
  std::optional<std::string> handle_line(std::string_view line, RpcContext& ctx) const;

  // Whether answering the message runs a slow method (then the whole message goes to a worker).
  bool is_slow(const nlohmann::json& message) const;

 private:
  nlohmann::json handle_one(const nlohmann::json& request, RpcContext& ctx, bool& reply) const;
  std::map<std::string, MethodSpec, std::less<>> methods_;
};

// A received line as JSON; throws RpcError(parse_error) naming what is wrong (also for nesting
// deeper than max_depth, which would otherwise cost the stack of whoever copies the value).
nlohmann::json parse_message(std::string_view line, int max_depth = 128);
// The error response {"jsonrpc": "2.0", "error": {code, message[, data]}, "id"}.
nlohmann::json error_response(const nlohmann::json& id, const RpcError& error);
// The reply to a message refused whole (e.g. over the pending limit): the error once for each
// request that has a usable id; nothing when all of it were notifications.
std::optional<nlohmann::json> refuse_message(const nlohmann::json& message, const RpcError& error);
// How many requests and notifications the message holds (a batch counts its members).
std::size_t message_size(const nlohmann::json& message);
// JSON text for the wire, without the newline; invalid UTF-8 from a handler is replaced, not thrown.
std::string to_wire(const nlohmann::json& value);

}  // namespace cmm::daemon
