// One dashboard WebSocket: messages to the dispatcher, slow ones to the workers, replies and
// notifications out through one bounded queue.
#include "daemon/web_socket_session.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <utility>

#include <boost/asio/post.hpp>

namespace cmm::daemon {

namespace beast = boost::beast;
namespace websocket = beast::websocket;

namespace {

std::chrono::steady_clock::duration seconds(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
}

std::string seconds_text(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", s);
  return text;
}

}  // namespace

WebSocketSession::WebSocketSession(beast::tcp_stream stream, std::uint64_t connection_id, std::string peer, Role role,
                                   WebSocketLimits limits, const RequestGate& gate, WebWorkers& workers,
                                   ByteBudget& budget, std::shared_ptr<void> slot, OnClosed on_closed)
    : ws_(std::move(stream)),
      context_(connection_id, std::move(peer), role),
      limits_(limits),
      gate_(gate),
      workers_(workers),
      budget_(budget),
      slot_(std::move(slot)),
      on_closed_(std::move(on_closed)),
      auth_timer_(ws_.get_executor()) {}

void WebSocketSession::start(Request upgrade) {
  beast::get_lowest_layer(ws_).expires_never();  // the WebSocket's own timeouts take over
  websocket::stream_base::timeout timeouts = websocket::stream_base::timeout::suggested(beast::role_type::server);
  timeouts.idle_timeout = seconds(limits_.idle_timeout_s);  // a ping at half of it; no pong by the end: closed
  timeouts.keep_alive_pings = true;
  ws_.set_option(timeouts);
  ws_.set_option(websocket::stream_base::decorator([](websocket::response_type& r) { r.set(beast::http::field::server, "cmmd"); }));
  // read() keeps the limit, not Beast's read_message_max: over that, Beast 1.74 fails the connection,
  // and its teardown closes the socket after one read of what the peer is still sending; the reset
  // loses the 1009 on its way. Our own close reads the rest of the message away first.
  ws_.read_message_max(0);
  ws_.text(true);
  ws_.async_accept(upgrade, [self = shared_from_this()](const beast::error_code& ec) { self->on_accept(ec); });
}

void WebSocketSession::on_accept(const beast::error_code& ec) {
  if (ec) return close("WebSocket handshake failed: " + ec.message());
  open_ = true;
  spdlog::info("connection {} opened: {} (role {})", context_.connection_id(), context_.peer(), to_string(context_.role()));
  if (limits_.auth_timeout_s > 0 && context_.role() == Role::none) {
    auth_timer_.expires_after(seconds(limits_.auth_timeout_s));
    auth_timer_.async_wait([self = shared_from_this()](const beast::error_code& timer_ec) {
      if (timer_ec || self->closed_ || self->context_.role() != Role::none) return;
      self->finish_after_output(std::string("not authenticated within auth_timeout_s (").append(seconds_text(self->limits_.auth_timeout_s)).append(" s)"),
                                websocket::close_code::policy_error);
    });
  }
  read();
}

void WebSocketSession::read() {
  reading_ = true;
  // In pieces, never more than one byte over the limit: a message over it is known before it is in memory.
  const std::size_t max_bytes = gate_.limits().max_request_bytes;
  const std::size_t room = max_bytes + 1 - std::min(inbox_.size(), max_bytes);
  ws_.async_read_some(inbox_, room,
                      [self = shared_from_this()](const beast::error_code& ec, std::size_t) { self->on_read(ec); });
}

void WebSocketSession::on_read(const beast::error_code& ec) {
  reading_ = false;
  if (closed_) return;
  if (ec == websocket::error::closed) return close(closing_ ? close_reason_ : "closed by the peer");
  if (ec == beast::error::timeout) return close(std::string("no frame and no pong for idle_timeout_s (").append(seconds_text(limits_.idle_timeout_s)).append(" s)"));
  if (ec) return close("read failed: " + ec.message());
  if (closing_) {  // what the peer sends after our close frame is dropped until its close frame comes
    inbox_.consume(inbox_.size());
    return read();
  }
  if (inbox_.size() > gate_.limits().max_request_bytes) {  // the other connections never see the bytes
    spdlog::warn("connection {} ({}): a message over max_request_bytes ({} bytes); closing", context_.connection_id(),
                 context_.peer(), gate_.limits().max_request_bytes);
    inbox_.consume(inbox_.size());
    return finish_after_output("a message over max_request_bytes", websocket::close_code::too_big);
  }
  if (!ws_.is_message_done()) return read();
  if (!ws_.got_text()) {
    inbox_.consume(inbox_.size());
    return finish_after_output("a binary message (JSON-RPC goes in text messages)", websocket::close_code::unknown_data);
  }
  const std::string text = beast::buffers_to_string(inbox_.data());
  inbox_.consume(inbox_.size());
  on_message(text);
  if (closed_ || closing_) return;
  if (context_.close_requested())
    return finish_after_output("closed after its reply, as a handler asked", websocket::close_code::policy_error);
  if (unsent_bytes_ > gate_.limits().max_request_bytes) {
    read_paused_ = true;  // the peer sends faster than it reads its replies: it reads first
    return;
  }
  read();
}

void WebSocketSession::on_message(std::string_view text) {
  GateDecision d = gate_.admit(text, context_, pending_, [this](Work work, std::size_t count, std::size_t bytes) {
    return workers_.admit(work, count, bytes);
  });
  switch (d.kind) {
    case GateDecision::Kind::nothing: return;
    case GateDecision::Kind::answer: return reply(d.answer);
    case GateDecision::Kind::run: return run_slow(std::move(d));
    case GateDecision::Kind::close:
      reply(d.answer);
      return finish_after_output(d.reason, websocket::close_code::policy_error);
  }
}

void WebSocketSession::run_slow(GateDecision d) {
  pending_ += d.count;
  const Work work = d.work;
  workers_.run(work, context_.role(), [self = shared_from_this(), d = std::move(d)] {
    std::optional<std::string> text = self->gate_.run(d.message, self->context_);
    self->workers_.release(d.work, d.count, d.bytes);
    boost::asio::post(self->ws_.get_executor(), [self, text = std::move(text), count = d.count]() mutable {
      self->pending_ -= count;
      if (text && !self->closing_) self->queue(std::make_shared<const std::string>(std::move(*text)));
    });
  });
}

void WebSocketSession::reply(const std::optional<nlohmann::json>& response) {
  if (response) queue(std::make_shared<const std::string>(to_wire(*response)));
}

void WebSocketSession::send_notification(std::shared_ptr<const std::string> text) {
  if (open_ && !closed_ && !closing_) queue(std::move(text));
}

void WebSocketSession::queue(std::shared_ptr<const std::string> text) {
  if (closed_) return;
  const std::size_t bytes = text->size();
  if (unsent_bytes_ + bytes > limits_.max_unsent_bytes || !budget_.take(bytes)) {
    spdlog::warn("connection {} ({}) dropped: {} bytes unsent, over max_unsent_bytes ({}) or the dashboard's budget for "
                 "all connections; a client that does not read what it is sent",
                 context_.connection_id(), context_.peer(), unsent_bytes_, limits_.max_unsent_bytes);
    return close("a client that does not read what it is sent");
  }
  unsent_bytes_ += bytes;
  outbox_.push_back(std::move(text));
  if (!writing_) write();
}

void WebSocketSession::write() {
  writing_ = true;
  ws_.async_write(boost::asio::buffer(*outbox_.front()),
                  [self = shared_from_this()](const beast::error_code& ec, std::size_t) { self->on_written(ec); });
}

void WebSocketSession::on_written(const beast::error_code& ec) {
  writing_ = false;
  if (closed_) return;  // close() gave the unsent bytes back already
  if (ec) return close("write failed: " + ec.message());
  const std::size_t bytes = outbox_.front()->size();
  outbox_.pop_front();
  unsent_bytes_ -= bytes;
  budget_.give(bytes);
  if (!outbox_.empty()) return write();
  if (closing_) return send_close();
  if (read_paused_ && !reading_ && unsent_bytes_ <= gate_.limits().max_request_bytes) {
    read_paused_ = false;
    read();
  }
}

void WebSocketSession::finish_after_output(const std::string& reason, websocket::close_code code) {
  if (closed_ || closing_) return;
  closing_ = true;
  close_reason_ = reason;
  close_code_ = code;
  spdlog::debug("connection {}: {}; closing", context_.connection_id(), reason);
  if (!writing_) send_close();
}

void WebSocketSession::send_close() {
  // The peer answers with its own close frame, which ends the pending read (or Beast's timeout does).
  websocket::close_reason why(close_code_, close_reason_.substr(0, 120));  // a control frame holds 125 bytes
  ws_.async_close(why, [self = shared_from_this()](const beast::error_code& ec) {
    if (ec || !self->reading_) self->close(self->close_reason_);
  });
}

void WebSocketSession::close(const std::string& reason) {
  if (closed_) return;
  closed_ = true;
  context_.mark_closed();
  auth_timer_.cancel();
  budget_.give(unsent_bytes_);  // the queue stays until a write in flight is done with it
  unsent_bytes_ = 0;
  beast::get_lowest_layer(ws_).close();
  if (open_)
    spdlog::info("connection {} closed: {} ({})", context_.connection_id(), context_.peer(), reason);
  else
    spdlog::debug("connection {} ({}) not opened: {}", context_.connection_id(), context_.peer(), reason);
  if (on_closed_) std::exchange(on_closed_, nullptr)(context_.connection_id());
}

}  // namespace cmm::daemon
