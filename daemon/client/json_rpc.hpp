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

#include "daemon/client/rpc_error.hpp"

namespace cmm::daemon {

// A connection id no other connection of this process has had, on any transport: jogs and logs
// tell clients apart by it.
std::uint64_t next_connection_id();

// One connection as its handlers see it. The role and the topics may change while a slow method
// runs on a worker thread (server.auth on the io thread), so they are read and written atomically.
class RpcContext {
 public:
  // `trusted`: the transport itself vouches for the client (the Unix socket's file permissions);
  // otherwise only a token makes it authenticated.
  RpcContext(std::uint64_t connection_id, std::string peer, Role role, bool trusted = false)
      : connection_id_(connection_id), peer_(std::move(peer)), client_(peer_ + " #" + std::to_string(connection_id)),
        role_(role), authenticated_(trusted) {}

  std::uint64_t connection_id() const { return connection_id_; }
  const std::string& peer() const { return peer_; }  // e.g. "tcp://127.0.0.1:50412", for logs
  // Who the client is across its requests: a connection, or an MQTT requester's reply topic, whose
  // requests each get a context of their own. A jog belongs to it.
  const std::string& client() const { return client_; }
  void set_client(std::string client) { client_ = std::move(client); }
  Role role() const { return role_.load(); }
  void set_role(Role role) { role_.store(role); }
  // Whether a token (or the transport's own trust) stands behind the role: an unauthenticated
  // connection is the first to go when the connection limits are reached.
  bool authenticated() const { return authenticated_.load(); }
  void mark_authenticated() { authenticated_.store(true); }
  // Set when the connection closes (its client left, or cmmd is stopping): a long handler still
  // running for it stops, since nobody will read its answer.
  bool closed() const { return closed_.load(); }
  void mark_closed() { closed_.store(true); }
  // A handler's word that the connection be closed once its reply is out (too many failed guesses).
  void close_after_reply() { close_requested_.store(true); }
  bool close_requested() const { return close_requested_.load(); }
  int count_failed_auth() { return ++failed_auths_; }  // returns the count so far
  bool subscribed_any() const;

  // Adds to the connection's topics; returns all of them, sorted.
  std::vector<std::string> subscribe(const std::vector<std::string>& topics);
  bool subscribed(const std::string& topic) const;

 private:
  std::uint64_t connection_id_;
  std::string peer_, client_;
  std::atomic<Role> role_;
  std::atomic<bool> authenticated_;
  std::atomic<bool> closed_{false}, close_requested_{false};
  std::atomic<int> failed_auths_{0};
  mutable std::mutex topics_mutex_;
  std::set<std::string> topics_;
};

// A handler returns the call's "result"; it throws RpcError for a JSON-RPC error, and any other
// std::exception becomes −32603 with its message.
using Handler = std::function<nlohmann::json(const nlohmann::json& params, RpcContext& ctx)>;

// Where the transport runs a method. Quick ones answer on the io thread; the others on worker
// pools, so that previews (planning) can never take the workers the machine and jobs need.
enum class Work {
  quick,     // no waiting: on the io thread
  blocking,  // waits for the machine or the disk: a worker of the caller's role
  planning,  // plans a model (seconds of CPU): a planning worker
};

struct MethodSpec {
  Role role = Role::operator_;  // the least role that may call it
  Work work = Work::quick;
  Handler handler;
};

class RpcDispatcher {
 public:
  // Register every method before a server starts serving; throws std::logic_error on a second
  // registration of one name or on an empty handler.
  void add(std::string method, MethodSpec spec);
  std::vector<std::string> methods() const;  // sorted
  // Called for each request answered (not for notifications), with the method it named ("" for an
  // invalid request) and whether the answer is an error; set before a server starts serving.
  using Answered = std::function<void(const std::string& method, bool error)>;
  void on_answered(Answered answered) { answered_ = std::move(answered); }

  // One message (a request, a notification or a batch) → its reply, or nothing when the spec
  // says no reply (a notification, a batch of notifications). `params` absent reads as {}.
  std::optional<nlohmann::json> handle(const nlohmann::json& message, RpcContext& ctx) const;
  // The same from and to wire text: a line that is not JSON is answered with −32700.
  std::optional<std::string> handle_line(std::string_view line, RpcContext& ctx) const;

  // Where answering the message for a caller of `role` runs: its heaviest method's place (a batch
  // goes whole); a single request above the role is quick, since its answer is the refusal.
  Work work_of(const nlohmann::json& message, Role role = Role::operator_) const;

 private:
  nlohmann::json handle_one(const nlohmann::json& request, RpcContext& ctx, bool& reply) const;
  nlohmann::json answer_one(const nlohmann::json& request, RpcContext& ctx, bool& reply) const;
  std::map<std::string, MethodSpec, std::less<>> methods_;
  Answered answered_;
};

// What a line may ask of the parser, checked on the text before a value is built: nesting deeper
// than max_depth would cost the stack of whoever copies the value, and a batch is bounded so that
// one line cannot become millions of replies.
struct ParseLimits {
  int max_depth = 128;
  std::size_t max_batch_entries = 128;
};

// A received line as JSON; throws RpcError naming what is wrong: parse_error (with data.byte) for
// text that is not JSON, a number beyond a double's range or nesting deeper than the limit;
// batch_too_large (data.max_batch_entries) for a batch of more entries than the limit.
nlohmann::json parse_message(std::string_view line, const ParseLimits& limits = {});
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
