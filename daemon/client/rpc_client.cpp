// The blocking JSON-RPC client over TCP or the Unix socket: calls, their replies, and notifications
// read while waiting.
#include "daemon/client/rpc_client.hpp"

#include <poll.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <deque>
#include <limits>

#include <asio/connect.hpp>
#include <asio/generic/stream_protocol.hpp>
#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/local/stream_protocol.hpp>
#include <asio/write.hpp>

#include "daemon/client/json_rpc.hpp"

namespace cmm::daemon {

namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

Clock::time_point deadline_in(double seconds) {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

std::string seconds_text(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%g s", seconds);
  return text;
}

std::string hint(const asio::error_code& ec) {
  // Asio's system errors have their own category, so they are compared as Asio's codes.
  if (ec == asio::error::connection_refused || ec == asio::error_code(ENOENT, asio::system_category()))
    return " — is cmmd running?";
  if (ec == asio::error::access_denied) return " — may this user open the socket (its group)?";
  return "";
}

RpcError error_from_reply(const json& error) {
  const auto code = error.find("code");
  const auto message = error.find("message");
  return RpcError(code != error.end() && code->is_number_integer() ? code->get<int>() : rpc_code::internal_error,
                  message != error.end() && message->is_string() ? message->get<std::string>() : to_wire(error),
                  error.value("data", json(nullptr)));
}

}  // namespace

struct RpcClient::Connection {
  std::string endpoint;
  asio::io_context io;
  asio::generic::stream_protocol::socket socket{io};
  std::array<char, 64 * 1024> buffer;
  std::string inbox;
  std::size_t scanned = 0;  // inbox before this holds no newline
  std::deque<json> notifications;
  std::int64_t next_id = 1;
  std::unique_ptr<StationLink> station;  // set: lines go through the broker, not the socket

  // Runs the connect started before it until it completes or the deadline passes (then it is
  // cancelled and completes with operation_aborted, unless it had completed already).
  void run(Clock::time_point deadline) {
    io.restart();
    io.run_until(deadline);
    if (io.stopped()) return;
    asio::error_code ignored;
    socket.cancel(ignored);
    io.restart();
    io.run();
  }

  [[noreturn]] void fail(const asio::error_code& ec, const std::string& doing) {
    if (ec == asio::error::eof || ec == asio::error::connection_reset || ec == asio::error::broken_pipe)
      throw RpcClientError(endpoint + ": connection closed by cmmd");
    throw RpcClientError(endpoint + ": " + doing + ": " + ec.message());
  }

  // After connecting, the socket is non-blocking and waits are poll(2) on it: a round trip costs
  // two system calls each way, as a bare blocking client's would, not an io_context run.
  bool wait(short events, Clock::time_point deadline) {
    for (;;) {
      const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return false;
      pollfd ready{socket.native_handle(), events, 0};
      const int n = ::poll(&ready, 1, static_cast<int>(std::min<long long>(left, 60'000)));
      if (n > 0) return true;
      if (n < 0 && errno != EINTR) fail(asio::error_code(errno, asio::system_category()), "cannot wait");
    }
  }

  // Reads once more into inbox; false when nothing came before the deadline.
  bool fill(Clock::time_point deadline) {
    for (;;) {
      asio::error_code ec;
      const std::size_t got = socket.read_some(asio::buffer(buffer), ec);
      if (!ec) {
        inbox.append(buffer.data(), got);
        return true;
      }
      if (ec != asio::error::would_block) fail(ec, "cannot read");
      if (!wait(POLLIN, deadline)) return false;
    }
  }

  std::optional<std::string> next_line(Clock::time_point deadline) {
    if (station) return station->next_line(deadline);
    for (;;) {
      if (const auto end = inbox.find('\n', scanned); end != std::string::npos) {
        std::string line = inbox.substr(0, end);
        inbox.erase(0, end + 1);
        scanned = 0;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        return line;
      }
      scanned = inbox.size();
      if (!fill(deadline)) return std::nullopt;
    }
  }

  void send(std::string_view bytes, double timeout_s) {
    if (station) {
      try {
        return station->send(bytes);
      } catch (const std::exception& e) {
        throw RpcClientError(e.what());
      }
    }
    const auto deadline = deadline_in(timeout_s);
    while (!bytes.empty()) {
      asio::error_code ec;
      bytes.remove_prefix(socket.write_some(asio::buffer(bytes), ec));
      if (!ec) continue;
      if (ec != asio::error::would_block) fail(ec, "cannot send");
      if (!wait(POLLOUT, deadline)) {
        // Part of the line may be out: the stream cannot be framed any more.
        socket.close(ec);
        throw RpcClientError(endpoint + ": cmmd took nothing for " + seconds_text(timeout_s) + "; connection closed");
      }
    }
  }

  // A server notification is queued; true when the line was one.
  bool keep_notification(const json& message) {
    if (!message.is_object() || message.contains("id") || !message.contains("method")) return false;
    notifications.push_back({{"method", message["method"]}, {"params", message.value("params", json::object())}});
    return true;
  }

  json parse(const std::string& line, const std::string& context) {
    try {
      return parse_message(line, {.max_depth = 128, .max_batch_entries = std::numeric_limits<std::size_t>::max()});
    } catch (const RpcError& e) {
      throw RpcClientError(endpoint + ": unreadable " + context + ": " + e.what());
    }
  }

  template <typename Endpoint>
  asio::error_code try_connect(const Endpoint& target, Clock::time_point deadline) {
    asio::error_code result = asio::error::would_block;
    asio::error_code ignored;
    socket.close(ignored);
    socket.async_connect(asio::generic::stream_protocol::endpoint(target), [&](const asio::error_code& ec) { result = ec; });
    run(deadline);
    return result;
  }
};

RpcClient::RpcClient(std::unique_ptr<Connection> connection) : connection_(std::move(connection)) {}
RpcClient::RpcClient(RpcClient&&) noexcept = default;
RpcClient& RpcClient::operator=(RpcClient&&) noexcept = default;
RpcClient::~RpcClient() = default;

RpcClient RpcClient::connect(const std::string& endpoint, double timeout_s) {
  auto c = std::make_unique<Connection>();
  c->endpoint = endpoint;
  const auto deadline = deadline_in(timeout_s);
  const std::string failed = "cannot connect to " + endpoint + ": ";
  asio::error_code ec = asio::error::invalid_argument;
  if (endpoint.rfind("unix:", 0) == 0 && endpoint.size() > 5) {
    ec = c->try_connect(asio::local::stream_protocol::endpoint(endpoint.substr(5)), deadline);
  } else if (const auto colon = endpoint.rfind(':'); endpoint.rfind("tcp://", 0) == 0 && colon > 6) {
    std::string host = endpoint.substr(6, colon - 6);
    if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
    asio::ip::tcp::resolver resolver(c->io);
    const auto found = resolver.resolve(host, endpoint.substr(colon + 1), asio::ip::resolver_base::numeric_service, ec);
    if (ec) throw RpcClientError(failed + "cannot resolve " + host + ": " + ec.message());
    for (const auto& entry : found)
      if (!(ec = c->try_connect(entry.endpoint(), deadline))) break;
    if (!ec) c->socket.set_option(asio::ip::tcp::no_delay(true), ec);
  } else {
    throw RpcClientError("endpoint \"" + endpoint + "\" is neither tcp://HOST:PORT nor unix:/PATH");
  }
  if (ec == asio::error::operation_aborted)
    throw RpcClientError(failed + "no answer within " + seconds_text(timeout_s) + " — is cmmd running?");
  if (ec) throw RpcClientError(failed + ec.message() + hint(ec));
  c->socket.non_blocking(true, ec);
  if (ec) throw RpcClientError(failed + ec.message());
  return RpcClient(std::move(c));
}

RpcClient RpcClient::connect_station(StationAddress address, double timeout_s) {
  auto c = std::make_unique<Connection>();
  try {
    c->station = std::make_unique<StationLink>(std::move(address), deadline_in(timeout_s));
  } catch (const std::exception& e) {
    throw RpcClientError(e.what());
  }
  c->endpoint = c->station->name();
  return RpcClient(std::move(c));
}

json RpcClient::call(const std::string& method, const json& params, double timeout_s) {
  Connection& c = *connection_;
  const std::int64_t id = c.next_id++;
  const auto deadline = deadline_in(timeout_s);
  c.send(to_wire({{"jsonrpc", "2.0"}, {"id", id}, {"method", method}, {"params", params}}) + "\n", timeout_s);
  for (;;) {
    const auto line = c.next_line(deadline);
    if (!line) throw RpcClientError(c.endpoint + ": no reply to " + method + " within " + seconds_text(timeout_s));
    const json message = c.parse(*line, "reply to " + method);
    if (c.keep_notification(message) || !message.is_object()) continue;
    const auto reply_id = message.find("id");
    if (reply_id == message.end()) continue;
    // An error without an id answers the request the server could not read: ours.
    const auto error = message.find("error");
    if (*reply_id != id && !(reply_id->is_null() && error != message.end())) continue;  // a late reply
    if (error != message.end()) throw error_from_reply(*error);
    return message.value("result", json(nullptr));
  }
}

void RpcClient::notify(const std::string& method, const json& params) {
  connection_->send(to_wire({{"jsonrpc", "2.0"}, {"method", method}, {"params", params}}) + "\n", 30);
}

std::optional<json> RpcClient::wait_notification(double timeout_s) {
  Connection& c = *connection_;
  const auto deadline = deadline_in(timeout_s);
  while (c.notifications.empty()) {
    const auto line = c.next_line(deadline);
    if (!line) return std::nullopt;
    c.keep_notification(c.parse(*line, "notification"));
  }
  json notification = std::move(c.notifications.front());
  c.notifications.pop_front();
  return notification;
}

void RpcClient::send_raw(std::string_view bytes) { connection_->send(bytes, 30); }

std::optional<std::string> RpcClient::read_line(double timeout_s) { return connection_->next_line(deadline_in(timeout_s)); }

const std::string& RpcClient::endpoint() const { return connection_->endpoint; }

void RpcClient::close() {
  connection_->station.reset();
  asio::error_code ignored;
  connection_->socket.close(ignored);
}

}  // namespace cmm::daemon
