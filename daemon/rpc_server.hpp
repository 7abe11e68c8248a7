// cmmd's JSON-RPC transport: newline-delimited JSON over TCP and a Unix socket on the caller's
// io_context, with the limits and access rules of docs/api.md, and notifications to subscribers.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/local/stream_protocol.hpp>
#include <nlohmann/json.hpp>

#include "daemon/byte_budget.hpp"
#include "daemon/client/json_rpc.hpp"
#include "daemon/request_gate.hpp"
#include "daemon/server_options.hpp"
#include "daemon/token_book.hpp"
#include "daemon/worker_pools.hpp"

namespace cmm::daemon {

class RpcSession;

// Runs on one thread: the one that runs the io_context (cmmd's main thread). Slow methods run on
// its own worker pool. Registers the builtins server.auth and server.subscribe in the dispatcher,
// which must outlive it and have all methods added before start().
class RpcServer {
 public:
  RpcServer(asio::io_context& io, RpcDispatcher& dispatcher, ServerOptions options);
  ~RpcServer();  // stop()
  RpcServer(const RpcServer&) = delete;
  RpcServer& operator=(const RpcServer&) = delete;

  // Binds and listens; throws std::runtime_error saying what and where (a non-loopback bind
  // without tokens, a port in use, a Unix path that is not a socket or is served by another).
  void start();
  int tcp_port() const { return tcp_port_; }  // the bound port, also when options asked for 0

  // Thread-safe: sends {"method", "params"} to every connection subscribed to topic.
  void notify(const std::string& topic, const std::string& method, const nlohmann::json& params);
  // Thread-safe (SIGHUP): new connections and later server.auth calls use these; roles already
  // granted stay.
  void set_tokens(std::vector<AccessToken> tokens);
  // What server.auth compares with, shared with the dashboard's server (WebServer), which runs the
  // same server.auth through the dispatcher and checks its report links' tokens here.
  TokenBook& tokens() { return tokens_; }
  // On the io thread (or with the io_context not running): closes the listeners and every
  // connection, removes the Unix socket, and joins the workers (after running slow methods return).
  void stop();
  std::size_t connection_count() const;  // thread-safe
  std::size_t unsent_bytes() const { return unsent_budget_.used(); }  // thread-safe: all connections' queues

 private:
  void listen_tcp();
  void listen_unix();
  void accept_tcp();
  void accept_unix();
  template <typename Socket>
  void admit(Socket socket, std::string peer, Role role, bool tcp);
  // On the io thread, for a new TCP connection: closes the oldest unauthenticated one when they
  // are at their limit, or all TCP connections are; false when no room can be made (all authenticated).
  bool make_room_for_tcp();
  nlohmann::json auth(const nlohmann::json& params, RpcContext& ctx);
  nlohmann::json subscribe(const nlohmann::json& params, RpcContext& ctx);

  asio::io_context& io_;
  RpcDispatcher& dispatcher_;
  const ServerOptions options_;
  std::optional<asio::ip::tcp::acceptor> tcp_acceptor_;
  std::optional<asio::local::stream_protocol::acceptor> unix_acceptor_;
  RequestGate gate_;
  std::optional<WorkerPools> workers_;
  ByteBudget unsent_budget_;
  int tcp_port_ = 0;
  bool started_ = false, stopped_ = false, unix_bound_ = false;
  std::shared_ptr<bool> alive_ = std::make_shared<bool>(true);  // accept handlers outliving us see it gone

  mutable std::mutex sessions_mutex_;
  std::map<std::uint64_t, std::shared_ptr<RpcSession>> sessions_;
  std::size_t tcp_sessions_ = 0, unix_sessions_ = 0;  // admitted, not refused
  TokenBook tokens_;
};

}  // namespace cmm::daemon
