// One HTTP connection of the dashboard's server (WebServer): GET and HEAD of the routes in
// web_routes.hpp, the Host check on every request, the Origin check on the WebSocket upgrade, which
// hands the connection to a WebSocketSession. Beast inside: include it only from the web server's files.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include "daemon/host_origin_check.hpp"
#include "daemon/token_book.hpp"
#include "daemon/web_routes.hpp"

namespace cmm::daemon {

// What the HTTP side serves, fixed once the server listens.
struct HttpSite {
  WebRoots roots;
  HostRules host_rules;
  std::filesystem::path jobs_dir;  // <state_dir>/jobs, for /jobs/<id>/report
  double idle_timeout_s = 30;      // a request not complete within this: closed
  TokenBook* tokens = nullptr;
  std::function<std::string()> metrics;  // /metrics's text; unset: not found
};

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  using Request = boost::beast::http::request<boost::beast::http::empty_body>;
  // Takes the connection over for the WebSocket; `slot` is the connection's place in the count.
  using Upgrade = std::function<void(boost::beast::tcp_stream stream, Request request, std::string peer,
                                     std::shared_ptr<void> slot)>;

  HttpSession(boost::beast::tcp_stream stream, std::string peer, const HttpSite& site, std::shared_ptr<void> slot,
              Upgrade upgrade);
  void start();
  // On the server's thread: HTTP carries no token, so a connection still speaking it is the first
  // to go at the dashboard's limits (a browser opens another when it needs one).
  bool evictable() const { return !upgraded_ && !closed_; }
  void close(const std::string& reason);

 private:
  void read();
  void on_read(const boost::beast::error_code& ec);
  void handle(Request request);
  void serve_file(const Request& request, const Route& route);
  void serve_report(const Request& request, const Route& route);
  void send_text(const Request& request, boost::beast::http::status status, const std::string& text);
  void send_metrics(const Request& request);
  template <class Response>
  void send(Response response);
  void on_written(const boost::beast::error_code& ec, bool close);

  boost::beast::tcp_stream stream_;
  std::string peer_;
  const HttpSite& site_;
  std::shared_ptr<void> slot_;
  Upgrade upgrade_;
  boost::beast::flat_buffer buffer_;
  std::optional<boost::beast::http::request_parser<boost::beast::http::empty_body>> parser_;
  bool upgraded_ = false, closed_ = false;
};

}  // namespace cmm::daemon
