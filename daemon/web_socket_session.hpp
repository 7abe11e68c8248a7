// One WebSocket connection of the dashboard's server: JSON-RPC 2.0, one message (request,
// notification or batch) per text frame, through the same dispatcher, roles and limits as a TCP
// connection (RpcSession); pings keep it alive. Beast inside: include it only from the web server's files.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>

#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include "daemon/byte_budget.hpp"
#include "daemon/client/json_rpc.hpp"
#include "daemon/request_gate.hpp"
#include "daemon/web_workers.hpp"

namespace cmm::daemon {

// The gate's limits apply too: a message over its max_request_bytes closes with 1009 (message too big).
struct WebSocketLimits {
  double idle_timeout_s;             // no frame, not even a pong, for this long: closed
  double auth_timeout_s;             // a connection of role none not authenticated by then: closed
  std::size_t max_unsent_bytes;      // replies and notifications not yet sent; more: dropped
};

// Every member function runs on the server's io thread; workers only post back to it.
class WebSocketSession : public std::enable_shared_from_this<WebSocketSession> {
 public:
  using Request = boost::beast::http::request<boost::beast::http::empty_body>;
  using OnClosed = std::function<void(std::uint64_t connection_id)>;

  WebSocketSession(boost::beast::tcp_stream stream, std::uint64_t connection_id, std::string peer, Role role,
                   WebSocketLimits limits, const RequestGate& gate, WebWorkers& workers, ByteBudget& budget,
                   std::shared_ptr<void> slot, OnClosed on_closed);

  void start(Request upgrade);  // answers the handshake, then reads
  void send_notification(std::shared_ptr<const std::string> text);
  void close(const std::string& reason);  // at once, without the closing handshake
  RpcContext& context() { return context_; }
  // Not authenticated by a token (an observer without tokens in cmmd.json is not): the first to go
  // at the dashboard's connection limits.
  bool evictable() const { return !closed_ && !closing_ && !context_.authenticated(); }

 private:
  void on_accept(const boost::beast::error_code& ec);
  void read();
  void on_read(const boost::beast::error_code& ec);
  void on_message(std::string_view text);
  void run_slow(GateDecision decision);
  void reply(const std::optional<nlohmann::json>& response);
  void queue(std::shared_ptr<const std::string> text);
  void write();
  void on_written(const boost::beast::error_code& ec);
  void finish_after_output(const std::string& reason, boost::beast::websocket::close_code code);
  void send_close();

  boost::beast::websocket::stream<boost::beast::tcp_stream> ws_;
  RpcContext context_;
  WebSocketLimits limits_;
  const RequestGate& gate_;
  WebWorkers& workers_;
  ByteBudget& budget_;
  std::shared_ptr<void> slot_;
  OnClosed on_closed_;
  boost::asio::steady_timer auth_timer_;
  boost::beast::flat_buffer inbox_;
  std::deque<std::shared_ptr<const std::string>> outbox_;
  std::size_t unsent_bytes_ = 0;
  std::size_t pending_ = 0;
  bool open_ = false;         // the handshake is done
  bool writing_ = false;
  bool reading_ = false;
  bool read_paused_ = false;  // too much unsent output: the peer must read first
  bool closing_ = false;      // the close frame goes after what is queued
  bool closed_ = false;
  std::string close_reason_;
  boost::beast::websocket::close_code close_code_ = boost::beast::websocket::close_code::normal;
};

}  // namespace cmm::daemon
