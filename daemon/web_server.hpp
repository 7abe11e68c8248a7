// cmmd's dashboard server: HTTP (the dashboard's files, Debian's three.js and Chart.js, the jobs'
// reports) and JSON-RPC over a WebSocket at /rpc, on Boost.Beast with an io_context and a thread of
// its own (docs/api.md, Dashboard transport). Beast stays behind this header.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "daemon/client/json_rpc.hpp"
#include "daemon/http_options.hpp"
#include "daemon/server_options.hpp"
#include "daemon/token_book.hpp"

namespace cmm::daemon {

// The dispatcher (with every method, server.auth and server.subscribe among them: RpcServer adds
// those) and the token book must outlive the server.
class WebServer {
 public:
  // `server` gives the bind address and the limits, which apply per WebSocket as per TCP connection
  // (max_connections counts the dashboard's connections apart); `jobs_dir` holds the job folders.
  WebServer(RpcDispatcher& dispatcher, TokenBook& tokens, const ServerOptions& server, HttpOptions http,
            std::filesystem::path jobs_dir);
  ~WebServer();  // stop()
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  // Binds on server.tcp_bind and starts the thread; throws std::runtime_error saying what and where
  // (a port in use, a bind beyond loopback without tokens).
  void start();
  int port() const;  // the bound port, also when asked for 0
  // Before start(): what /metrics serves (Prometheus's text format); unset, /metrics is not found.
  void serve_metrics(std::function<std::string()> metrics);

  // Thread-safe: sends {"method", "params"} to every WebSocket subscribed to topic.
  void notify(const std::string& topic, const std::string& method, const nlohmann::json& params);
  // Thread-safe, from any thread but the server's: closes the listener and every connection, joins
  // the workers (running slow methods finish) and the thread.
  void stop();
  std::size_t connection_count() const;  // open WebSockets; thread-safe

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cmm::daemon
