// One JSON-RPC connection of RpcServer (TCP or Unix alike): framing, the per-connection limits,
// slow methods handed to the workers, and an output queue that notifications share.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <asio/generic/stream_protocol.hpp>
#include <asio/steady_timer.hpp>
#include <asio/thread_pool.hpp>

#include "daemon/json_rpc.hpp"

namespace cmm::daemon {

struct SessionLimits {
  std::size_t max_request_bytes;
  std::size_t max_pending_requests;
  double idle_timeout_s;
  std::size_t max_unsent_bytes;
};

// Every member function runs on the io thread; workers only post back to it.
class RpcSession : public std::enable_shared_from_this<RpcSession> {
 public:
  using Socket = asio::generic::stream_protocol::socket;
  using OnClosed = std::function<void(std::uint64_t connection_id)>;

  RpcSession(Socket socket, std::uint64_t connection_id, std::string peer, Role role, SessionLimits limits,
             const RpcDispatcher& dispatcher, asio::thread_pool& workers, OnClosed on_closed);

  void start();
  // Sends one error line and closes: the connection is over a server-wide limit.
  void refuse(const RpcError& error);
  void send_notification(std::shared_ptr<const std::string> line);
  void close(const std::string& reason);

  RpcContext& context() { return context_; }

 private:
  void read();
  void on_read(const asio::error_code& ec, std::size_t n);
  void on_line(std::string_view line);
  void run_slow(nlohmann::json message, std::size_t count);
  void reply(const std::optional<nlohmann::json>& response);
  void queue(std::shared_ptr<const std::string> line);
  void write();
  void on_written(const asio::error_code& ec, std::size_t lines, std::size_t bytes);
  void arm_idle_timer();
  void close_after_write(const RpcError& error);
  void drain();
  void finish_if_done();

  Socket socket_;
  RpcContext context_;
  SessionLimits limits_;
  const RpcDispatcher& dispatcher_;
  asio::thread_pool& workers_;
  OnClosed on_closed_;
  asio::steady_timer timer_;
  std::uint64_t timer_generation_ = 0;

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
