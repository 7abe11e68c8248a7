// One client connection: reading lines, dispatching requests to the worker pools, sending replies
// and notifications within its budget.
#include "daemon/rpc_session.hpp"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <utility>

#include <asio/post.hpp>
#include <asio/write.hpp>

namespace cmm::daemon {

namespace {

using Clock = std::chrono::steady_clock;
constexpr std::size_t kLinesPerWrite = 64;
const char kNewline = '\n';

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

std::string seconds_text(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", s);
  return text;
}

}  // namespace

RpcSession::RpcSession(Socket socket, std::uint64_t connection_id, std::string peer, Role role, bool trusted,
                       SessionLimits limits, const RequestGate& gate, WorkerPools& workers, ByteBudget& budget,
                       OnClosed on_closed)
    : socket_(std::move(socket)),
      context_(connection_id, std::move(peer), role, trusted),
      limits_(limits),
      gate_(gate),
      workers_(workers),
      budget_(budget),
      on_closed_(std::move(on_closed)),
      timer_(socket_.get_executor()),
      auth_timer_(socket_.get_executor()),
      last_bytes_(Clock::now()),
      last_line_(last_bytes_) {}

void RpcSession::start() {
  spdlog::info("connection {} opened: {} (role {})", context_.connection_id(), context_.peer(), to_string(context_.role()));
  arm_idle_timer();
  arm_auth_timer();
  read();
}

void RpcSession::refuse(const RpcError& error) {
  spdlog::warn("connection from {} refused: {}", context_.peer(), error.what());
  close_after_write(error);
}

void RpcSession::evict(const std::string& reason) {
  spdlog::warn("connection {} ({}) closed: {}", context_.connection_id(), context_.peer(), reason);
  close(reason);
}

void RpcSession::read() {
  socket_.async_read_some(asio::buffer(read_buffer_),
                          [self = shared_from_this()](const asio::error_code& ec, std::size_t n) { self->on_read(ec, n); });
}

void RpcSession::on_read(const asio::error_code& ec, std::size_t n) {
  if (closed_) return;
  if (closing_) {  // the last line is out or going; what the peer still sends is discarded until it closes
    if (ec) return close(close_reason_);
    return read();
  }
  if (ec) {
    if (ec != asio::error::eof) return close("read failed: " + ec.message());
    if (!inbox_.empty()) spdlog::debug("connection {}: {} bytes after the last newline dropped", context_.connection_id(), inbox_.size());
    peer_done_ = true;
    ++timer_generation_;
    timer_.cancel();
    return finish_if_done();
  }
  last_bytes_ = Clock::now();
  inbox_.append(read_buffer_.data(), n);
  const std::size_t max_bytes = gate_.limits().max_request_bytes;
  std::size_t begin = 0;
  for (auto end = inbox_.find(kNewline, scanned_); end != std::string::npos; end = inbox_.find(kNewline, begin)) {
    std::string_view line(inbox_.data() + begin, end - begin);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    begin = end + 1;
    last_line_ = last_bytes_;
    on_line(line);
    if (closed_ || closing_) return;
    if (context_.close_requested()) return finish_after_output("closed after its reply, as a handler asked");
  }
  inbox_.erase(0, begin);
  scanned_ = inbox_.size();
  if (inbox_.size() > max_bytes + 1) {  // + 1: a '\r'
    reply(gate_.too_large(inbox_.size()));
    return finish_after_output("a request over max_request_bytes");
  }
  if (const std::optional<std::string> refused = gate_.refuse_partial(inbox_, context_)) return close(*refused);
  if (unsent_bytes_ > max_bytes) {
    // The peer sends faster than it reads its replies: stop reading until it catches up.
    read_paused_ = true;
    ++timer_generation_;
    timer_.cancel();
    return;
  }
  arm_idle_timer();
  read();
}

void RpcSession::on_line(std::string_view line) {
  GateDecision d = gate_.admit(line, context_, pending_, [this](Work work, std::size_t count, std::size_t bytes) {
    return workers_.admit(work, count, bytes);
  });
  switch (d.kind) {
    case GateDecision::Kind::nothing: return;
    case GateDecision::Kind::answer: return reply(d.answer);
    case GateDecision::Kind::run: return run_slow(std::move(d));
    case GateDecision::Kind::close:
      if (!d.answer) return close(d.reason);
      reply(d.answer);
      return finish_after_output(d.reason);
  }
}

void RpcSession::run_slow(GateDecision d) {
  pending_ += d.count;
  asio::post(workers_.pool(d.work, context_.role()), [self = shared_from_this(), d = std::move(d)] {
    std::optional<std::string> line = self->gate_.run(d.message, self->context_);
    self->workers_.release(d.work, d.count, d.bytes);
    asio::post(self->socket_.get_executor(), [self, line = std::move(line), count = d.count]() mutable {
      self->pending_ -= count;
      if (line && !self->closing_) self->queue(std::make_shared<const std::string>(std::move(*line)));
      if (!self->closed_ && !self->closing_ && !self->read_paused_ && !self->peer_done_) self->arm_idle_timer();
      self->finish_if_done();
    });
  });
}

void RpcSession::reply(const std::optional<nlohmann::json>& response) {
  if (response) queue(std::make_shared<const std::string>(to_wire(*response)));
}

void RpcSession::send_notification(std::shared_ptr<const std::string> line) {
  if (closed_ || closing_) return;
  queue(std::move(line));
}

void RpcSession::queue(std::shared_ptr<const std::string> line) {
  if (closed_) return;
  const std::size_t bytes = line->size() + 1;
  if (unsent_bytes_ + bytes > limits_.max_unsent_bytes || !budget_.take(bytes)) {
    spdlog::warn("connection {} ({}) dropped: {} bytes unsent, over max_unsent_bytes ({}) or cmmd's budget for all "
                 "connections; a client that does not read what it is sent",
                 context_.connection_id(), context_.peer(), unsent_bytes_, limits_.max_unsent_bytes);
    return close("a client that does not read what it is sent");
  }
  unsent_bytes_ += bytes;
  last_line_ = Clock::now();
  outbox_.push_back(std::move(line));
  if (!writing_) write();
}

void RpcSession::write() {
  writing_ = true;
  write_buffers_.clear();
  std::size_t lines = 0, bytes = 0;
  for (; lines < outbox_.size() && lines < kLinesPerWrite; ++lines) {
    write_buffers_.push_back(asio::buffer(*outbox_[lines]));
    write_buffers_.push_back(asio::buffer(&kNewline, 1));
    bytes += outbox_[lines]->size() + 1;
  }
  asio::async_write(socket_, write_buffers_,
                    [self = shared_from_this(), lines, bytes](const asio::error_code& ec, std::size_t) {
                      self->on_written(ec, lines, bytes);
                    });
}

void RpcSession::on_written(const asio::error_code& ec, std::size_t lines, std::size_t bytes) {
  writing_ = false;
  if (closed_) return;  // close() gave the unsent bytes back already
  if (ec) return close("write failed: " + ec.message());
  outbox_.erase(outbox_.begin(), outbox_.begin() + static_cast<std::ptrdiff_t>(lines));
  unsent_bytes_ -= bytes;
  budget_.give(bytes);
  if (read_paused_ && !closing_ && unsent_bytes_ <= gate_.limits().max_request_bytes) {
    read_paused_ = false;
    arm_idle_timer();
    read();
  }
  if (!outbox_.empty()) return write();
  if (closing_) return drain();
  if (!read_paused_ && !peer_done_) arm_idle_timer();
  finish_if_done();
}

// One timer for both idle rules (docs/api.md, Transport): a partial line followed by silence, and a
// TCP connection that has not subscribed, waits for no reply, and sends no complete line.
void RpcSession::arm_idle_timer() {
  const std::uint64_t generation = ++timer_generation_;
  const Clock::duration idle = seconds(limits_.idle_timeout_s);
  const bool silent_rule = limits_.tcp && pending_ == 0 && outbox_.empty() && !context_.subscribed_any();
  if (inbox_.empty() && !silent_rule) {
    timer_.cancel();
    return;
  }
  Clock::time_point deadline = Clock::time_point::max();
  if (!inbox_.empty()) deadline = last_bytes_ + idle;
  if (silent_rule) deadline = std::min(deadline, last_line_ + idle);
  timer_.expires_at(deadline);
  timer_.async_wait([self = shared_from_this(), generation](const asio::error_code& ec) {
    if (ec || self->closed_ || generation != self->timer_generation_) return;
    self->on_idle_timer();
  });
}

void RpcSession::on_idle_timer() {
  const Clock::time_point now = Clock::now();
  const Clock::duration idle = seconds(limits_.idle_timeout_s);
  if (!inbox_.empty() && now - last_bytes_ >= idle)
    return close("a partial request, then nothing for " + seconds_text(limits_.idle_timeout_s) + " s");
  if (limits_.tcp && pending_ == 0 && outbox_.empty() && !context_.subscribed_any() && now - last_line_ >= idle)
    return close("no request for " + seconds_text(limits_.idle_timeout_s) + " s on a TCP connection that has not subscribed");
  arm_idle_timer();
}

void RpcSession::arm_auth_timer() {
  if (limits_.auth_timeout_s <= 0 || context_.authenticated()) return;
  auth_timer_.expires_after(seconds(limits_.auth_timeout_s));
  auth_timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
    if (ec || self->closed_ || self->context_.authenticated()) return;
    self->close("not authenticated within auth_timeout_s (" + seconds_text(self->limits_.auth_timeout_s) + " s)");
  });
}

void RpcSession::close_after_write(const RpcError& error) {
  reply(error_response(nullptr, error));
  finish_after_output(error.what());
}

void RpcSession::finish_after_output(const std::string& reason) {
  if (closed_) return;
  closing_ = true;
  close_reason_ = reason;
  ++timer_generation_;
  timer_.cancel();
  spdlog::debug("connection {}: {}; closing", context_.connection_id(), reason);
  if (!writing_ && outbox_.empty()) drain();
}

void RpcSession::drain() {
  // Closing with unread input would reset the connection and could destroy the last line in
  // flight, so: FIN first, then read and discard until the peer closes (or idle_timeout_s).
  asio::error_code ignored;
  socket_.shutdown(Socket::shutdown_send, ignored);
  const std::uint64_t generation = ++timer_generation_;
  timer_.expires_after(seconds(limits_.idle_timeout_s));
  timer_.async_wait([self = shared_from_this(), generation](const asio::error_code& ec) {
    if (!ec && generation == self->timer_generation_) self->close(self->close_reason_);
  });
  read();
}

void RpcSession::finish_if_done() {
  if (peer_done_ && !closing_ && pending_ == 0 && !writing_ && outbox_.empty()) close("closed by the peer");
}

void RpcSession::close(const std::string& reason) {
  if (closed_) return;
  closed_ = true;
  context_.mark_closed();
  ++timer_generation_;
  timer_.cancel();
  auth_timer_.cancel();
  budget_.give(unsent_bytes_);  // the queue stays until a write in flight is done with it
  unsent_bytes_ = 0;
  asio::error_code ignored;
  socket_.shutdown(Socket::shutdown_both, ignored);
  socket_.close(ignored);
  spdlog::info("connection {} closed: {} ({})", context_.connection_id(), context_.peer(), reason);
  if (on_closed_) std::exchange(on_closed_, nullptr)(context_.connection_id());
}

}  // namespace cmm::daemon
