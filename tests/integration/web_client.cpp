// Beast's HTTP and WebSocket clients behind deadlines: each operation runs on a private io_context
// for at most its time, then the socket is closed and the test told.
#include "web_client.hpp"

#include <chrono>
#include <deque>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

namespace cmm::testing {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;
using nlohmann::json;

namespace {

std::chrono::steady_clock::duration seconds(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
}

// Starts `start(handler)` and runs the io_context until the handler ran or the time is up; on
// time-out closes `socket` (which ends the operation) and throws.
template <class Socket, class Start>
beast::error_code run_for(net::io_context& io, Socket& socket, double timeout_s, const std::string& what, Start start) {
  std::optional<beast::error_code> result;
  start([&result](const beast::error_code& ec, auto&&...) { result = ec; });
  io.restart();
  io.run_for(seconds(timeout_s));
  if (!result) {
    beast::error_code ignored;
    socket.close(ignored);
    io.restart();
    io.run();
    throw std::runtime_error(what + ": nothing within " + std::to_string(timeout_s) + " s");
  }
  return *result;
}

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

tcp::endpoint loopback(int port) { return {net::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port)}; }

}  // namespace

std::string HttpReply::header(const std::string& lower_case_name) const {
  const auto found = headers.find(lower_case_name);
  return found == headers.end() ? std::string() : found->second;
}

HttpReply http_request(int port, const std::string& method, const std::string& target, const Headers& headers) {
  net::io_context io;
  tcp::socket socket(io);
  const std::string what = method + " " + target;
  if (const auto ec = run_for(io, socket, 10, what + ": connect", [&](auto h) { socket.async_connect(loopback(port), h); }))
    throw std::runtime_error(what + ": connect: " + ec.message());
  http::request<http::string_body> request{http::string_to_verb(method), target, 11};
  request.set(http::field::host, "127.0.0.1:" + std::to_string(port));
  for (const auto& [name, value] : headers) request.set(name, value);
  request.prepare_payload();
  if (const auto ec = run_for(io, socket, 10, what + ": write", [&](auto h) { http::async_write(socket, request, h); }))
    throw std::runtime_error(what + ": write: " + ec.message());
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(64u << 20);
  parser.skip(method == "HEAD");
  if (const auto ec = run_for(io, socket, 30, what + ": read", [&](auto h) { http::async_read(socket, buffer, parser, h); }))
    throw std::runtime_error(what + ": read: " + ec.message());
  HttpReply reply;
  reply.status = parser.get().result_int();
  for (const auto& field : parser.get()) reply.headers[lower(std::string(field.name_string()))] = std::string(field.value());
  reply.body = parser.get().body();
  return reply;
}

WebSocketRefused::WebSocketRefused(int status, const std::string& body)
    : std::runtime_error("the WebSocket upgrade was answered " + std::to_string(status) + ": " + body), status(status) {}

struct WebSocketClient::Impl {
  net::io_context io;
  websocket::stream<tcp::socket> ws{io};
  beast::flat_buffer buffer;
  std::deque<json> notifications;
  int next_id = 1;
  int close_code = 0;
};

WebSocketClient::WebSocketClient(int port, const Headers& headers) : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  tcp::socket& socket = s.ws.next_layer();
  if (const auto ec = run_for(s.io, socket, 10, "ws connect", [&](auto h) { socket.async_connect(loopback(port), h); }))
    throw std::runtime_error("ws connect: " + ec.message());
  std::string host = "127.0.0.1:" + std::to_string(port);
  Headers extra;
  for (const auto& [name, value] : headers) {
    if (lower(name) == "host") host = value;
    else extra[name] = value;
  }
  s.ws.set_option(websocket::stream_base::decorator([extra](websocket::request_type& request) {
    for (const auto& [name, value] : extra) request.set(name, value);
  }));
  s.ws.read_message_max(64u << 20);
  websocket::response_type response;
  const auto ec = run_for(s.io, socket, 10, "ws handshake", [&](auto h) { s.ws.async_handshake(response, host, "/rpc", h); });
  if (ec == websocket::error::upgrade_declined) throw WebSocketRefused(response.result_int(), response.body());
  if (ec) throw std::runtime_error("ws handshake: " + ec.message());
}

WebSocketClient::~WebSocketClient() {
  beast::error_code ignored;
  impl_->ws.next_layer().close(ignored);
}

bool WebSocketClient::send_text(const std::string& text, double timeout_s) {
  Impl& s = *impl_;
  s.ws.text(true);
  return !run_for(s.io, s.ws.next_layer(), timeout_s, "ws write", [&](auto h) { s.ws.async_write(net::buffer(text), h); });
}

std::optional<json> WebSocketClient::receive(double timeout_s) {
  Impl& s = *impl_;
  s.buffer.consume(s.buffer.size());
  const auto ec = run_for(s.io, s.ws.next_layer(), timeout_s, "ws read", [&](auto h) { s.ws.async_read(s.buffer, h); });
  if (ec) {
    s.close_code = s.ws.reason().code;
    return std::nullopt;
  }
  return json::parse(beast::buffers_to_string(s.buffer.data()));
}

int WebSocketClient::close_code() const { return impl_->close_code; }

json WebSocketClient::call(const std::string& method, const json& params, double timeout_s) {
  Impl& s = *impl_;
  const int id = s.next_id++;
  if (!send_text(json{{"jsonrpc", "2.0"}, {"id", id}, {"method", method}, {"params", params}}.dump()))
    throw std::runtime_error(method + ": the connection is closed");
  const auto deadline = std::chrono::steady_clock::now() + seconds(timeout_s);
  for (;;) {
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    const std::optional<json> message = receive(std::max(left, 0.001));
    if (!message) throw std::runtime_error(method + ": closed by cmmd (code " + std::to_string(s.close_code) + ")");
    if (!message->contains("id")) {
      s.notifications.push_back(*message);
      continue;
    }
    if ((*message)["id"] != id) continue;
    if (message->contains("error")) {
      const json& e = (*message)["error"];
      throw daemon::RpcError(e.at("code").get<int>(), e.at("message").get<std::string>(), e.value("data", json(nullptr)));
    }
    return message->at("result");
  }
}

daemon::RpcError WebSocketClient::error_of(const std::string& method, const json& params) {
  try {
    const json result = call(method, params);
    throw std::runtime_error(method + " succeeded: " + result.dump());
  } catch (const daemon::RpcError& e) {
    return e;
  }
}

json WebSocketClient::wait_notification(const std::string& what, const std::function<bool(const json&)>& match,
                                        double timeout_s) {
  Impl& s = *impl_;
  const auto deadline = std::chrono::steady_clock::now() + seconds(timeout_s);
  for (;;) {
    while (!s.notifications.empty()) {
      json n = std::move(s.notifications.front());
      s.notifications.pop_front();
      if (match(n)) return n;
    }
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) throw std::runtime_error("no notification " + what + " within " + std::to_string(timeout_s) + " s");
    const std::optional<json> message = receive(left);
    if (!message) throw std::runtime_error("waiting for " + what + ": closed by cmmd");
    if (!message->contains("id")) s.notifications.push_back(*message);
  }
}

}  // namespace cmm::testing
