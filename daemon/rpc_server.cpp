// The JSON-RPC server: listening on TCP and the Unix socket, sessions, tokens, notifications and
// the shared byte budgets.
#include "daemon/rpc_server.hpp"

#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/stat.h>

#include <filesystem>
#include <stdexcept>

#include <asio/post.hpp>
#include <asio/steady_timer.hpp>

#include "daemon/rpc_session.hpp"

namespace cmm::daemon {

namespace {

using nlohmann::json;

std::string tcp_peer(const asio::ip::tcp::socket& socket) {
  asio::error_code ec;
  const auto remote = socket.remote_endpoint(ec);
  if (ec) return "tcp://?";
  const auto address = remote.address();
  return "tcp://" + (address.is_v6() ? "[" + address.to_string() + "]" : address.to_string()) + ":" +
         std::to_string(remote.port());
}

std::string unix_peer(asio::local::stream_protocol::socket& socket, const std::string& path) {
  ucred cred{};
  socklen_t size = sizeof cred;
  if (getsockopt(socket.native_handle(), SOL_SOCKET, SO_PEERCRED, &cred, &size) != 0) return "unix:" + path;
  return "unix:" + path + " (pid " + std::to_string(cred.pid) + ", uid " + std::to_string(cred.uid) + ")";
}

// A failed accept (e.g. out of file descriptors) is retried after a pause, not in a busy loop.
template <typename Retry>
void retry_accept_later(asio::io_context& io, const asio::error_code& ec, const char* where, Retry retry) {
  spdlog::warn("accepting on {} failed: {}; retrying in 0.1 s", where, ec.message());
  auto timer = std::make_shared<asio::steady_timer>(io, std::chrono::milliseconds(100));
  timer->async_wait([timer, retry](const asio::error_code&) { retry(); });
}

}  // namespace

RpcServer::RpcServer(asio::io_context& io, RpcDispatcher& dispatcher, ServerOptions options)
    : io_(io),
      dispatcher_(dispatcher),
      options_(std::move(options)),
      gate_(dispatcher_, gate_limits(options_), Framing::lines),
      unsent_budget_(options_.max_total_unsent_bytes),
      tokens_(options_.tokens, options_.auth_guesses_per_s, options_.auth_guess_burst) {
  dispatcher_.add("server.auth", {Role::none, Work::quick, [this](const json& p, RpcContext& c) { return auth(p, c); }});
  dispatcher_.add("server.subscribe",
                  {Role::observer, Work::quick, [this](const json& p, RpcContext& c) { return subscribe(p, c); }});
}

RpcServer::~RpcServer() { stop(); }

void RpcServer::start() {
  if (started_) throw std::logic_error("RpcServer::start called twice");
  started_ = true;
  workers_.emplace(options_.workers);
  if (options_.tcp_enabled) listen_tcp();
  if (!options_.unix_path.empty()) listen_unix();
  if (tcp_acceptor_) accept_tcp();
  if (unix_acceptor_) accept_unix();
}

void RpcServer::listen_tcp() {
  const std::string where = "tcp://" + options_.tcp_bind + ":" + std::to_string(options_.tcp_port);
  asio::ip::tcp::resolver resolver(io_);
  asio::error_code ec;
  const auto found = resolver.resolve(options_.tcp_bind, std::to_string(options_.tcp_port),
                                      asio::ip::resolver_base::passive | asio::ip::resolver_base::numeric_service, ec);
  if (ec || found.empty()) throw std::runtime_error("cannot listen on " + where + ": " + ec.message());
  const asio::ip::tcp::endpoint endpoint = found.begin()->endpoint();
  if (options_.tokens.empty() && !endpoint.address().is_loopback())
    throw std::runtime_error("refusing to listen on " + where + ": server.tcp_bind is not a loopback address and no " +
                             "server.tokens are set (anyone who reaches the port could move the machine); " +
                             "set tokens or bind 127.0.0.1");
  try {
    tcp_acceptor_.emplace(io_);
    tcp_acceptor_->open(endpoint.protocol());
    tcp_acceptor_->set_option(asio::socket_base::reuse_address(true));
    tcp_acceptor_->bind(endpoint);
    tcp_acceptor_->listen(asio::socket_base::max_listen_connections);
  } catch (const asio::system_error& e) {
    tcp_acceptor_.reset();
    throw std::runtime_error("cannot listen on " + where + ": " + e.code().message());
  }
  tcp_port_ = tcp_acceptor_->local_endpoint().port();
  spdlog::info("JSON-RPC listening on tcp://{}:{} (a token makes a client operator or observer)",
               endpoint.address().to_string(), tcp_port_);
}

void RpcServer::listen_unix() {
  namespace fs = std::filesystem;
  const std::string& path = options_.unix_path;
  const std::string where = "unix:" + path;
  struct stat st {};
  if (lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode))
      throw std::runtime_error("cannot listen on " + where + ": the path exists and is not a socket; remove it or " +
                               "set server.unix_path to another path");
    asio::local::stream_protocol::socket probe(io_);
    asio::error_code ec;
    probe.connect(asio::local::stream_protocol::endpoint(path), ec);
    if (!ec) throw std::runtime_error("cannot listen on " + where + ": another process is listening on it (a second cmmd?)");
    if (ec != asio::error::connection_refused)
      throw std::runtime_error("cannot listen on " + where + ": cannot tell whether it is in use: " + ec.message());
    std::error_code removed;
    if (!fs::remove(path, removed) && removed)
      throw std::runtime_error("cannot remove the stale socket " + path + ": " + removed.message());
    spdlog::info("removed the stale socket {} (nothing listened on it)", path);
  }
  try {
    unix_acceptor_.emplace(io_);
    unix_acceptor_->open();
    unix_acceptor_->bind(asio::local::stream_protocol::endpoint(path));
  } catch (const asio::system_error& e) {
    unix_acceptor_.reset();
    throw std::runtime_error("cannot listen on " + where + ": " + e.code().message());
  }
  unix_bound_ = true;
  // chmod before listen(): no client can connect while the socket still has umask's mode.
  if (::chmod(path.c_str(), options_.unix_mode) != 0)
    throw std::runtime_error("cannot set the mode of " + where + ": " + std::error_code(errno, std::generic_category()).message());
  asio::error_code ec;
  unix_acceptor_->listen(asio::socket_base::max_listen_connections, ec);
  if (ec) throw std::runtime_error("cannot listen on " + where + ": " + ec.message());
  spdlog::info("JSON-RPC listening on {} (mode {:o}, operator)", where, options_.unix_mode);
}

void RpcServer::accept_tcp() {
  tcp_acceptor_->async_accept([this, alive = std::weak_ptr<bool>(alive_)](const asio::error_code& ec,
                                                                           asio::ip::tcp::socket socket) {
    if (alive.expired() || stopped_) return;
    if (ec) return retry_accept_later(io_, ec, "tcp", [this, alive] { if (!alive.expired() && !stopped_) accept_tcp(); });
    asio::error_code ignored;
    socket.set_option(asio::ip::tcp::no_delay(true), ignored);
    std::string peer = tcp_peer(socket);
    admit(std::move(socket), std::move(peer), Role::none, true);  // never operator by address: by a token only
    accept_tcp();
  });
}

void RpcServer::accept_unix() {
  unix_acceptor_->async_accept([this, alive = std::weak_ptr<bool>(alive_)](const asio::error_code& ec,
                                                                            asio::local::stream_protocol::socket socket) {
    if (alive.expired() || stopped_) return;
    if (ec) return retry_accept_later(io_, ec, "unix", [this, alive] { if (!alive.expired() && !stopped_) accept_unix(); });
    std::string peer = unix_peer(socket, options_.unix_path);
    admit(std::move(socket), std::move(peer), Role::operator_, false);
    accept_unix();
  });
}

template <typename Socket>
void RpcServer::admit(Socket socket, std::string peer, Role role, bool tcp) {
  const std::uint64_t id = next_connection_id();
  const SessionLimits limits{.idle_timeout_s = options_.idle_timeout_s,
                             .auth_timeout_s = options_.auth_timeout_s,
                             .max_unsent_bytes = options_.max_unsent_bytes,
                             .tcp = tcp};
  // Each transport counts its own connections: idle TCP clients cannot lock cmmctl out of the Unix socket.
  const int allowed = tcp ? options_.max_connections : options_.max_unix_connections;
  const char* limit_name = tcp ? "max_connections" : "max_unix_connections";
  auto session = std::make_shared<RpcSession>(RpcSession::Socket(std::move(socket)), id, std::move(peer), role,
                                              /*trusted=*/!tcp, limits, gate_, *workers_, unsent_budget_, nullptr);
  const bool room = !tcp || make_room_for_tcp();
  bool over;
  {
    std::lock_guard lock(sessions_mutex_);
    std::size_t& open = tcp ? tcp_sessions_ : unix_sessions_;
    over = !room || open >= static_cast<std::size_t>(std::max(0, allowed));
    if (!over) ++open;
    sessions_.emplace(id, session);  // a refused one too, so that stop() closes it
  }
  session->set_on_closed([this, tcp, counted = !over](std::uint64_t closed) {
    std::lock_guard lock(sessions_mutex_);
    sessions_.erase(closed);
    if (counted) --(tcp ? tcp_sessions_ : unix_sessions_);
  });
  if (over)
    session->refuse(RpcError(rpc_code::too_many_connections,
                             std::string("more than ") + limit_name + " (" + std::to_string(allowed) + ") connections",
                             {{limit_name, allowed}}));
  else
    session->start();
}

bool RpcServer::make_room_for_tcp() {
  std::shared_ptr<RpcSession> oldest;
  std::size_t unauthenticated = 0;
  bool full;
  {
    std::lock_guard lock(sessions_mutex_);
    full = tcp_sessions_ >= static_cast<std::size_t>(std::max(0, options_.max_connections));
    for (const auto& [id, session] : sessions_) {  // in id order: the first found is the oldest
      if (!session->counts_as_unauthenticated_tcp()) continue;
      if (!oldest) oldest = session;
      ++unauthenticated;
    }
  }
  const bool at_limit = unauthenticated >= static_cast<std::size_t>(std::max(1, options_.max_unauthenticated_connections));
  if (!full && !at_limit) return true;
  if (!oldest) return false;
  // Closed now, not after a reply: its count is free before the new one is counted.
  oldest->evict(std::string("an unauthenticated connection closed to make room for a new one (") +
                (full ? "max_connections" : "max_unauthenticated_connections") + " reached)");
  return true;
}

void RpcServer::notify(const std::string& topic, const std::string& method, const json& params) {
  const auto line = std::make_shared<const std::string>(to_wire({{"jsonrpc", "2.0"}, {"method", method}, {"params", params}}));
  std::lock_guard lock(sessions_mutex_);
  for (const auto& [id, session] : sessions_)
    // session = session: clang 14 cannot capture a structured binding (C++20 allows it, clang 16 does).
    if (session->context().subscribed(topic))
      asio::post(io_, [session = session, line] { session->send_notification(line); });
}

void RpcServer::set_tokens(std::vector<AccessToken> tokens) { tokens_.set_configured(std::move(tokens)); }

std::size_t RpcServer::connection_count() const {
  std::lock_guard lock(sessions_mutex_);
  return sessions_.size();
}

void RpcServer::stop() {
  if (stopped_) return;
  stopped_ = true;
  alive_.reset();
  asio::error_code ignored;
  if (tcp_acceptor_) tcp_acceptor_->close(ignored);
  if (unix_acceptor_) unix_acceptor_->close(ignored);
  if (unix_bound_) {
    std::error_code removed;
    std::filesystem::remove(options_.unix_path, removed);
  }
  std::map<std::uint64_t, std::shared_ptr<RpcSession>> sessions;
  {
    std::lock_guard lock(sessions_mutex_);
    sessions.swap(sessions_);
  }
  for (const auto& [id, session] : sessions) session->close("cmmd is stopping");
  if (workers_) workers_->stop_and_join();  // queued slow requests are dropped; running ones finish
  if (started_) spdlog::info("JSON-RPC server stopped ({} connections closed)", sessions.size());
}

json RpcServer::auth(const json& params, RpcContext& ctx) {
  const auto token = params.find("token");
  if (!params.is_object() || token == params.end() || !token->is_string())
    throw_invalid_param("/token", "server.auth needs {\"token\": string}");
  const Role role = authenticate(tokens_, token->get_ref<const std::string&>(), ctx, auth_source(ctx.peer()));
  spdlog::info("connection {} ({}) authenticated: role {}", ctx.connection_id(), ctx.peer(), to_string(role));
  return {{"role", to_string(role)}};
}

json RpcServer::subscribe(const json& params, RpcContext& ctx) {
  const auto topics = params.find("topics");
  if (!params.is_object() || topics == params.end() || !topics->is_array())
    throw_invalid_param("/topics", "server.subscribe needs {\"topics\": [string, ...]}");
  std::vector<std::string> wanted;
  for (std::size_t i = 0; i < topics->size(); ++i) {
    const json& topic = (*topics)[i];
    const bool known = topic.is_string() && std::find(options_.topics.begin(), options_.topics.end(),
                                                      topic.get_ref<const std::string&>()) != options_.topics.end();
    if (!known)
      throw_invalid_param("/topics/" + std::to_string(i),
                          "unknown topic " + to_wire(topic) + " (known: " + json(options_.topics).dump() + ")");
    wanted.push_back(topic);
  }
  return {{"topics", ctx.subscribe(wanted)}};
}

}  // namespace cmm::daemon
