// One JSON-RPC connection of RpcServer (TCP or Unix alike): framing, the per-connection limits,
// slow methods handed to the workers, and an output queue that notifications share.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <asio/generic/stream_protocol.hpp>
#include <asio/steady_timer.hpp>

#include "daemon/byte_budget.hpp"
#include "daemon/client/json_rpc.hpp"
#include "daemon/request_gate.hpp"
#include "daemon/worker_pools.hpp"

namespace cmm::daemon {

struct SessionLimits {
  double idle_timeout_s;
  double auth_timeout_s;  // <= 0: no deadline to authenticate
  std::size_t max_unsent_bytes;
  bool tcp;               // TCP (closed when silent and not subscribed) or the Unix socket
};

// Every member function runs on the io thread; workers only post back to it.
class RpcSession : public std::enable_shared_from_this<RpcSession> {
 public:
  using Socket = asio::generic::stream_protocol::socket;
  using OnClosed = std::function<void(std::uint64_t connection_id)>;

  // `trusted`: the Unix socket, whose file permissions vouch for the client (operator, authenticated).
  RpcSession(Socket socket, std::uint64_t connection_id, std::string peer, Role role, bool trusted, SessionLimits limits,
             const RequestGate& gate, WorkerPools& workers, ByteBudget& budget, OnClosed on_closed);

  void start();
  void set_on_closed(OnClosed on_closed) { on_closed_ = std::move(on_closed); }
  // Sends one error line and closes: the connection is over a server-wide limit.
  void refuse(const RpcError& error);
  void send_notification(std::shared_ptr<const std::string> line);
  void close(const std::string& reason);
  // Closes at once, with a log line: an unauthenticated connection making room for a new one.
  void evict(const std::string& reason);
  // An open TCP connection no token has authenticated yet: the first to go at the limits.
  bool counts_as_unauthenticated_tcp() const { return limits_.tcp && !closed_ && !closing_ && !context_.authenticated(); }

  RpcContext& context() { return context_; }

 private:
  void read();
  void on_read(const asio::error_code& ec, std::size_t n);
  void on_line(std::string_view line);
  void run_slow(GateDecision decision);
  void reply(const std::optional<nlohmann::json>& response);
  void queue(std::shared_ptr<const std::string> line);
  void write();
  void on_written(const asio::error_code& ec, std::size_t lines, std::size_t bytes);
  void arm_idle_timer();
  void on_idle_timer();
  void arm_auth_timer();
  void close_after_write(const RpcError& error);
  void finish_after_output(const std::string& reason);
  void drain();
  void finish_if_done();

  Socket socket_;
  RpcContext context_;
  SessionLimits limits_;
  const RequestGate& gate_;
  WorkerPools& workers_;
  ByteBudget& budget_;
  OnClosed on_closed_;
  asio::steady_timer timer_;       // idle, and the close's drain
  asio::steady_timer auth_timer_;
  std::uint64_t timer_generation_ = 0;
  std::chrono::steady_clock::time_point last_bytes_;  // anything read
  std::chrono::steady_clock::time_point last_line_;   // a complete line read, or a reply queued

  std::array<char, 64 * 1024> read_buffer_;
  std::string inbox_;           // bytes of lines not yet complete
  std::size_t scanned_ = 0;     // inbox_ before this holds no newline
  std::deque<std::shared_ptr<const std::string>> outbox_;  // lines without their newline
  std::vector<asio::const_buffer> write_buffers_;
  std::size_t unsent_bytes_ = 0;
  std::size_t pending_ = 0;     // requests on the workers
  bool writing_ = false;
  bool read_paused_ = false;    // too much unsent output: the peer must read first
  bool peer_done_ = false;      // EOF: answer what is pending, then close
  bool closing_ = false;        // an error line is the last thing sent
  bool closed_ = false;
  std::string close_reason_;
};

}  // namespace cmm::daemon
