// The dashboard server: its listener and thread, the count of its connections, the WebSockets that
// notifications go to, and the stop.
#include "daemon/web_server.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <functional>
#include <future>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>

#include "daemon/http_session.hpp"
#include "daemon/static_files.hpp"
#include "daemon/web_socket_session.hpp"

namespace cmm::daemon {

namespace net = boost::asio;
namespace beast = boost::beast;
using tcp = net::ip::tcp;

namespace {

// Holds one place in the connection count for as long as the HTTP session, then the WebSocket, lives.
struct ConnectionSlot {
  explicit ConnectionSlot(std::atomic<std::size_t>& open) : open_(open) { ++open_; }
  ~ConnectionSlot() { --open_; }
  ConnectionSlot(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(const ConnectionSlot&) = delete;
  std::atomic<std::size_t>& open_;
};

std::string peer_of(const tcp::socket& socket) {
  beast::error_code ec;
  const tcp::endpoint remote = socket.remote_endpoint(ec);
  if (ec) return "?";
  const auto address = remote.address();
  std::string peer = address.is_v6() ? "[" + address.to_string() + "]" : address.to_string();
  return peer.append(":").append(std::to_string(remote.port()));
}

}  // namespace

struct WebServer::Impl {
  Impl(RpcDispatcher& dispatcher, TokenBook& tokens, const ServerOptions& server, HttpOptions http,
       std::filesystem::path jobs_dir)
      : dispatcher(dispatcher),
        tokens(tokens),
        server(server),
        http(std::move(http)),
        gate(dispatcher, gate_limits(server), Framing::messages),
        budget(server.max_total_unsent_bytes) {
    site.roots.web_root = this->http.web_root.empty() ? default_web_root() : this->http.web_root;
    site.host_rules = {.port = 0, .bind = server.tcp_bind, .allowed_origins = this->http.allowed_origins};
    site.jobs_dir = std::move(jobs_dir);
    // HTTP carries no token: a request gets the short unauthenticated deadline to arrive whole.
    site.idle_timeout_s = std::min(server.idle_timeout_s, server.auth_timeout_s);
    site.tokens = &tokens;
  }

  void listen();
  void accept();
  void upgrade(beast::tcp_stream stream, HttpSession::Request request, std::string peer, std::shared_ptr<void> slot);
  bool make_room();
  void close_all();

  // What the sessions use comes before the io_context: destroying it destroys the handlers that
  // still hold sessions, and their slots and budgets must still be there then.
  RpcDispatcher& dispatcher;
  TokenBook& tokens;
  const ServerOptions server;
  const HttpOptions http;
  RequestGate gate;
  HttpSite site;
  ByteBudget budget;
  std::optional<WebWorkers> workers;
  std::atomic<std::size_t> open_connections{0};
  mutable std::mutex sessions_mutex;
  net::io_context io{1};
  // The sockets after it: closed before it goes.
  std::optional<tcp::acceptor> acceptor;
  std::map<std::uint64_t, std::shared_ptr<WebSocketSession>> sessions;
  std::map<std::uint64_t, std::weak_ptr<HttpSession>> http_sessions;  // the server's thread only
  std::thread thread;
  bool started = false, stopped = false;
};

void WebServer::Impl::listen() {
  const std::string where = std::string("http://").append(server.tcp_bind).append(":").append(std::to_string(http.port));
  tcp::resolver resolver(io);
  beast::error_code ec;
  const auto found = resolver.resolve(server.tcp_bind, std::to_string(http.port),
                                      tcp::resolver::passive | tcp::resolver::numeric_service, ec);
  if (ec || found.empty()) throw std::runtime_error("cannot listen on " + where + ": " + ec.message());
  const tcp::endpoint endpoint = found.begin()->endpoint();
  if (!tokens.any_configured() && !endpoint.address().is_loopback())
    throw std::runtime_error("refusing to serve the dashboard on " + where + ": server.tcp_bind is not a loopback " +
                             "address and no server.tokens are set; set tokens or bind 127.0.0.1");
  try {
    acceptor.emplace(io);
    acceptor->open(endpoint.protocol());
    acceptor->set_option(net::socket_base::reuse_address(true));
    acceptor->bind(endpoint);
    acceptor->listen(net::socket_base::max_listen_connections);
  } catch (const boost::system::system_error& e) {
    acceptor.reset();
    throw std::runtime_error("cannot listen on " + where + ": " + e.code().message() + " (http.port)");
  }
  site.host_rules.port = acceptor->local_endpoint().port();
}

void WebServer::Impl::accept() {
  acceptor->async_accept([this](const beast::error_code& ec, tcp::socket socket) {
    if (stopped || ec == net::error::operation_aborted) return;
    if (ec) {
      // Out of file descriptors, say: retried after a pause, not in a busy loop.
      spdlog::warn("dashboard: accepting failed: {}; retrying in 0.1 s", ec.message());
      auto timer = std::make_shared<net::steady_timer>(io, std::chrono::milliseconds(100));
      return timer->async_wait([this, timer](const beast::error_code&) { if (!stopped) accept(); });
    }
    beast::error_code ignored;
    socket.set_option(tcp::no_delay(true), ignored);
    std::string peer = peer_of(socket);
    if (!make_room()) {
      spdlog::warn("dashboard connection from {} refused: more than max_connections ({}), all authenticated", peer,
                   server.max_connections);
      socket.close(ignored);
      return accept();
    }
    auto slot = std::make_shared<ConnectionSlot>(open_connections);
    auto session = std::make_shared<HttpSession>(
        beast::tcp_stream(std::move(socket)), std::move(peer), site, std::move(slot),
        [this](beast::tcp_stream stream, HttpSession::Request request, std::string who, std::shared_ptr<void> held) {
          upgrade(std::move(stream), std::move(request), std::move(who), std::move(held));
        });
    http_sessions.emplace(next_connection_id(), session);
    session->start();
    accept();
  });
}

// Unauthenticated connections (plain HTTP, WebSockets no token raised) have a budget of their own;
// at it, or at max_connections, the oldest of them is closed for the new one. An authenticated
// WebSocket is never closed for them, so idle or half-sent connections cannot keep STOP out.
bool WebServer::Impl::make_room() {
  std::erase_if(http_sessions, [](const auto& entry) { return entry.second.expired(); });
  std::uint64_t oldest_id = 0;
  std::function<void()> evict_oldest;
  std::size_t evictable = 0;
  for (const auto& [id, weak] : http_sessions)
    if (const auto http_session = weak.lock(); http_session && http_session->evictable()) {
      if (++evictable == 1) {
        oldest_id = id;
        evict_oldest = [http_session] { http_session->close("closed to make room for a new connection"); };
      }
    }
  {
    std::lock_guard lock(sessions_mutex);
    for (const auto& [id, ws] : sessions)
      if (ws->evictable()) {
        if (++evictable == 1 || id < oldest_id) {
          oldest_id = id;
          evict_oldest = [ws = ws] { ws->close("an unauthenticated WebSocket closed to make room for a new connection"); };
        }
      }
  }
  const bool full = open_connections.load() >= static_cast<std::size_t>(std::max(0, server.max_connections));
  const bool at_limit = evictable >= static_cast<std::size_t>(std::max(1, server.max_unauthenticated_connections));
  if (!full && !at_limit) return true;
  if (!evict_oldest) return false;
  evict_oldest();
  return true;
}

void WebServer::Impl::upgrade(beast::tcp_stream stream, HttpSession::Request request, std::string peer,
                              std::shared_ptr<void> slot) {
  if (stopped) return;  // a request that was on its way while the server stopped: dropped with its socket
  // The operator's role is never granted here: without tokens an observer, a token raises it.
  const Role role = tokens.any_configured() ? Role::none : Role::observer;
  const WebSocketLimits limits{.idle_timeout_s = server.idle_timeout_s,
                               .auth_timeout_s = server.auth_timeout_s,
                               .max_unsent_bytes = server.max_unsent_bytes};
  const std::uint64_t id = next_connection_id();
  auto session = std::make_shared<WebSocketSession>(std::move(stream), id, "ws://" + peer, role, limits, gate,
                                                    *workers, budget, std::move(slot), [this](std::uint64_t closed) {
                                                      std::lock_guard lock(sessions_mutex);
                                                      sessions.erase(closed);
                                                    });
  {
    std::lock_guard lock(sessions_mutex);
    sessions.emplace(id, session);
  }
  session->start(std::move(request));
}

void WebServer::Impl::close_all() {
  beast::error_code ignored;
  if (acceptor) acceptor->close(ignored);
  std::map<std::uint64_t, std::shared_ptr<WebSocketSession>> open;
  {
    std::lock_guard lock(sessions_mutex);
    open.swap(sessions);
  }
  for (const auto& [id, session] : open) session->close("cmmd is stopping");
}

WebServer::WebServer(RpcDispatcher& dispatcher, TokenBook& tokens, const ServerOptions& server, HttpOptions http,
                     std::filesystem::path jobs_dir)
    : impl_(std::make_unique<Impl>(dispatcher, tokens, server, std::move(http), std::move(jobs_dir))) {}

WebServer::~WebServer() { stop(); }

void WebServer::start() {
  Impl& s = *impl_;
  if (s.started) throw std::logic_error("WebServer::start called twice");
  s.started = true;
  s.listen();
  s.workers.emplace(s.server.workers);
  s.accept();
  s.thread = std::thread([&s] {
    for (;;) {
      try {
        s.io.run();
        return;
      } catch (const std::exception& e) {  // a handler's failure ends that handler, not the server
        spdlog::error("dashboard server: {}", e.what());
      }
    }
  });
  spdlog::info("dashboard listening on http://{}:{} (web root {})", s.server.tcp_bind, port(), s.site.roots.web_root.string());
}

int WebServer::port() const { return impl_->site.host_rules.port; }

void WebServer::serve_metrics(std::function<std::string()> metrics) {
  if (impl_->started) throw std::logic_error("WebServer::serve_metrics after start");
  impl_->site.metrics = std::move(metrics);
}

void WebServer::notify(const std::string& topic, const std::string& method, const nlohmann::json& params) {
  Impl& s = *impl_;
  const auto text = std::make_shared<const std::string>(to_wire({{"jsonrpc", "2.0"}, {"method", method}, {"params", params}}));
  std::lock_guard lock(s.sessions_mutex);
  for (const auto& [id, session] : s.sessions)
    if (session->context().subscribed(topic))
      net::post(s.io, [session = session, text] { session->send_notification(text); });
}

void WebServer::stop() {
  Impl& s = *impl_;
  if (s.stopped || !s.started) {
    s.stopped = true;
    return;
  }
  // The closing runs on the server's thread, which owns the sockets; this one waits for it.
  std::promise<void> closed;
  net::post(s.io, [&s, &closed] {
    s.stopped = true;
    s.close_all();
    closed.set_value();
  });
  if (s.thread.joinable()) closed.get_future().wait();
  if (s.workers) s.workers->stop_and_join();  // queued slow requests are dropped; running ones finish
  s.io.stop();
  if (s.thread.joinable()) s.thread.join();
  spdlog::info("dashboard server stopped");
}

std::size_t WebServer::connection_count() const {
  std::lock_guard lock(impl_->sessions_mutex);
  return impl_->sessions.size();
}

}  // namespace cmm::daemon
