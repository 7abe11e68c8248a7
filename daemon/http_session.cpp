// The dashboard's HTTP requests: checks, routes, files, reports, and the hand-over to the WebSocket.
#include "daemon/http_session.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdio>

#include <boost/beast/websocket/rfc6455.hpp>

#include "daemon/static_files.hpp"

namespace cmm::daemon {

namespace beast = boost::beast;
namespace http = beast::http;

namespace {

constexpr std::size_t kHeaderLimit = 16 * 1024;  // a request's line and headers; GET carries no body

// Headers on every answer: no type guessing by the browser, no framing by a foreign page, and no
// Referer telling the sites a page links to which station and job it came from (no URL here
// carries a token: a report's is refused in web_routes).
template <class Response>
void set_common(Response& response, const http::request<http::empty_body>& request, const char* cache) {
  response.set(http::field::server, "cmmd");
  response.set(http::field::cache_control, cache);
  response.set("X-Content-Type-Options", "nosniff");
  response.set("X-Frame-Options", "SAMEORIGIN");
  response.set("Referrer-Policy", "no-referrer");
  response.keep_alive(request.keep_alive());
}

// The token of "Authorization: Bearer <token>"; "" without one.
std::string bearer_token(const http::request<http::empty_body>& request) {
  const beast::string_view scheme = "Bearer ", value = request[http::field::authorization];
  if (value.size() <= scheme.size() || !beast::iequals(value.substr(0, scheme.size()), scheme)) return {};
  return std::string(value.data() + scheme.size(), value.size() - scheme.size());
}

// The request's target for a message, cut short: a log or an answer never carries a megabyte of URL.
std::string shown_target(const http::request<http::empty_body>& request) {
  const auto target = request.target();
  return std::string(target.data(), std::min<std::size_t>(target.size(), 200));
}

}  // namespace

HttpSession::HttpSession(beast::tcp_stream stream, std::string peer, const HttpSite& site, std::shared_ptr<void> slot,
                         Upgrade upgrade)
    : stream_(std::move(stream)), peer_(std::move(peer)), site_(site), slot_(std::move(slot)), upgrade_(std::move(upgrade)) {}

void HttpSession::start() { read(); }

void HttpSession::close(const std::string& reason) {
  if (closed_ || upgraded_) return;
  closed_ = true;
  spdlog::warn("dashboard {}: connection closed: {}", peer_, reason);
  beast::error_code ignored;
  stream_.socket().close(ignored);  // the read in progress ends with operation_aborted
}

void HttpSession::read() {
  parser_.emplace();
  parser_->header_limit(kHeaderLimit);
  parser_->body_limit(0);
  stream_.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(site_.idle_timeout_s)));
  http::async_read(stream_, buffer_, *parser_,
                   [self = shared_from_this()](const beast::error_code& ec, std::size_t) { self->on_read(ec); });
}

void HttpSession::on_read(const beast::error_code& ec) {
  if (closed_) return;
  if (ec == http::error::end_of_stream || ec == beast::error::timeout || ec == boost::asio::error::operation_aborted ||
      ec == boost::asio::error::connection_reset || ec == boost::asio::error::eof) {
    beast::error_code ignored;
    stream_.socket().shutdown(boost::asio::ip::tcp::socket::shutdown_send, ignored);
    return;
  }
  if (ec) {
    spdlog::debug("dashboard {}: a request that does not parse: {}", peer_, ec.message());
    http::response<http::string_body> response{http::status::bad_request, 11};
    response.set(http::field::server, "cmmd");
    response.set(http::field::content_type, "text/plain; charset=utf-8");
    response.body() = "bad request: " + ec.message() + "\n";
    response.keep_alive(false);
    response.prepare_payload();
    return send(std::move(response));
  }
  handle(parser_->release());
}

void HttpSession::handle(Request request) {
  const std::string host(request[http::field::host]);
  if (!host_allowed(host, site_.host_rules)) {
    spdlog::warn("dashboard {}: refused a request for Host \"{}\" (not this station's name: DNS rebinding?)", peer_, host);
    return send_text(request, http::status::forbidden,
                     "Host \"" + host + "\" is not served here: use localhost, a loopback address or the bind address, "
                     "with the port (or list the origin in http.allowed_origins)");
  }
  if (request.method() != http::verb::get && request.method() != http::verb::head) {
    http::response<http::string_body> response{http::status::method_not_allowed, request.version()};
    set_common(response, request, "no-store");
    response.set(http::field::allow, "GET, HEAD");
    response.set(http::field::content_type, "text/plain; charset=utf-8");
    response.body() = "only GET and HEAD are served\n";
    response.prepare_payload();
    return send(std::move(response));
  }
  const Route route = route_of(std::string_view(request.target().data(), request.target().size()), site_.roots);
  if (beast::websocket::is_upgrade(request)) {
    if (route.kind != RouteKind::rpc) return send_text(request, http::status::not_found, "no WebSocket here: it is at /rpc");
    const std::string origin(request[http::field::origin]);
    if (request.find(http::field::origin) != request.end() && !origin_allowed(origin, host, site_.host_rules)) {
      spdlog::warn("dashboard {}: refused a WebSocket from the page of {} (not this dashboard's origin)", peer_, origin);
      return send_text(request, http::status::forbidden,
                       "Origin \"" + origin + "\" may not open cmmd's WebSocket (allowed: http://" + host +
                           " and http.allowed_origins)");
    }
    buffer_.consume(buffer_.size());  // a client waits for the handshake before it sends frames
    upgraded_ = true;
    return upgrade_(std::move(stream_), std::move(request), std::move(peer_), std::move(slot_));
  }
  switch (route.kind) {
    case RouteKind::file: return serve_file(request, route);
    case RouteKind::job_report: return serve_report(request, route);
    case RouteKind::bad_request: return send_text(request, http::status::bad_request, route.problem);
    case RouteKind::metrics:
      if (!site_.metrics) break;
      return send_metrics(request);
    case RouteKind::rpc:
      return send_text(request, http::status::upgrade_required, "cmmd's JSON-RPC WebSocket: connect with a WebSocket client");
    case RouteKind::not_found: break;
  }
  send_text(request, http::status::not_found, std::string("not found: ").append(shown_target(request)));
}

void HttpSession::serve_file(const Request& request, const Route& route) {
  const ResolvedFile file = resolve_under(route.root, route.relative);
  if (file.lookup == FileLookup::bad_path) return send_text(request, http::status::bad_request, "a path with \"..\" or NUL");
  if (file.lookup == FileLookup::not_found)
    return send_text(request, http::status::not_found, std::string("not found: ").append(shown_target(request)));
  const char* cache = route.web_root ? "no-cache" : "public, max-age=3600";
  beast::error_code ec;
  http::file_body::value_type body;
  body.open(file.path.c_str(), beast::file_mode::scan, ec);
  if (ec) return send_text(request, http::status::not_found, "cannot read " + route.relative + ": " + ec.message());
  const std::uint64_t size = body.size();
  if (request.method() == http::verb::head) {
    http::response<http::empty_body> response{http::status::ok, request.version()};
    set_common(response, request, cache);
    response.set(http::field::content_type, content_type(file.path));
    response.content_length(size);
    return send(std::move(response));
  }
  http::response<http::file_body> response{std::piecewise_construct, std::make_tuple(std::move(body)),
                                            std::make_tuple(http::status::ok, request.version())};
  set_common(response, request, cache);
  response.set(http::field::content_type, content_type(file.path));
  response.content_length(size);
  send(std::move(response));
}

void HttpSession::serve_report(const Request& request, const Route& route) {
  // Without tokens in cmmd.json the server is loopback-only and observers need none (as on the
  // WebSocket). With them, the dashboard gets reports over its authenticated WebSocket (job.report)
  // and the token comes in a header, which no history, log or printed page keeps.
  if (site_.tokens->any_configured()) {
    const std::string token = bearer_token(request);
    if (token.empty())
      return send_text(request, http::status::unauthorized,
                       "a report needs \"Authorization: Bearer <token>\" with an observer or operator token "
                       "(the dashboard's Report link opens it over the page's own connection)");
    const TokenCheck checked = site_.tokens->check(token, auth_source("http://" + peer_));
    if (checked.throttled)
      return send_text(request, http::status::too_many_requests, "too many wrong tokens lately: try again later");
    if (!checked.role || *checked.role < Role::observer) {
      spdlog::warn("dashboard {}: a report asked for with an unknown token", peer_);
      return send_text(request, http::status::forbidden, "unknown token");
    }
  }
  char folder[16];
  std::snprintf(folder, sizeof folder, "%06d", route.job);
  Route file = route;
  file.kind = RouteKind::file;
  file.root = site_.jobs_dir / folder;
  file.relative = "report.html";
  file.web_root = true;  // rewritten when the job is resumed and ends again: no-cache
  std::error_code ec;
  if (!std::filesystem::is_directory(file.root, ec))
    return send_text(request, http::status::not_found, std::string("no job ").append(std::to_string(route.job)));
  if (!std::filesystem::exists(file.root / file.relative, ec))
    return send_text(request, http::status::not_found,
                     std::string("job ").append(std::to_string(route.job)).append(" has no report yet: it is written when the job ends"));
  serve_file(request, file);
}

void HttpSession::send_text(const Request& request, http::status status, const std::string& text) {
  http::response<http::string_body> response{status, request.version()};
  set_common(response, request, "no-store");
  response.set(http::field::content_type, "text/plain; charset=utf-8");
  if (status == http::status::upgrade_required) response.set(http::field::upgrade, "websocket");
  if (request.method() != http::verb::head) response.body() = text + "\n";
  response.prepare_payload();
  if (request.method() == http::verb::head) response.content_length(text.size() + 1);
  send(std::move(response));
}

void HttpSession::send_metrics(const Request& request) {
  const std::string text = site_.metrics();
  http::response<http::string_body> response{http::status::ok, request.version()};
  set_common(response, request, "no-store");
  response.set(http::field::content_type, "text/plain; version=0.0.4; charset=utf-8");  // Prometheus's text format
  if (request.method() != http::verb::head) response.body() = text;
  response.prepare_payload();
  if (request.method() == http::verb::head) response.content_length(text.size());
  send(std::move(response));
}

template <class Response>
void HttpSession::send(Response response) {
  auto message = std::make_shared<Response>(std::move(response));
  const bool close = message->need_eof();
  http::async_write(stream_, *message, [self = shared_from_this(), message, close](const beast::error_code& ec, std::size_t) {
    self->on_written(ec, close);
  });
}

void HttpSession::on_written(const beast::error_code& ec, bool close) {
  if (ec || closed_) return;  // the peer went away: nothing left to do, the session ends with this handler
  if (!close) return read();
  beast::error_code ignored;
  stream_.socket().shutdown(boost::asio::ip::tcp::socket::shutdown_send, ignored);
}

}  // namespace cmm::daemon
