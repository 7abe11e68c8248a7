// Fuzzes the dashboard's HTTP side: a connection's bytes read into requests by Beast's parser with
// HttpSession's limits (16 KiB of line and headers, no body), then what HttpSession::handle decides
// from each: the Host check, the route, an upgrade's Origin check, and a file route's lookup under
// its root. The session itself needs a socket, so its order of checks is mirrored here, not called.
// Promises held: no file outside its root is ever found, a ".." segment is never served, a report's
// job id is a non-negative number the target spelled in digits.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include <boost/asio/buffer.hpp>
#include <boost/beast/http/empty_body.hpp>
#include <boost/beast/http/parser.hpp>
#include <boost/beast/websocket/rfc6455.hpp>

#include "daemon/host_origin_check.hpp"
#include "daemon/static_files.hpp"
#include "daemon/web_routes.hpp"
#include "fuzz_support.hpp"

namespace {

namespace http = boost::beast::http;
using namespace cmm::daemon;

constexpr std::size_t kHeaderLimit = 16 * 1024;  // daemon/http_session.cpp

bool has_dotdot_segment(std::string_view path) {
  std::size_t begin = 0;
  while (begin <= path.size()) {
    const std::size_t end = std::min(path.find('/', begin), path.size());
    if (path.substr(begin, end - begin) == "..") return true;
    begin = end + 1;
  }
  return false;
}

void check_file(const Route& route) {
  const ResolvedFile file = resolve_under(route.root, route.relative);
  if (file.lookup != FileLookup::found) return;
  if (has_dotdot_segment(route.relative)) __builtin_trap();
  std::error_code ec;
  const std::string root = std::filesystem::canonical(route.root, ec).string() + "/";
  if (ec || file.path.string().compare(0, root.size(), root) != 0) __builtin_trap();
}

void handle(const http::request<http::empty_body>& request, const WebRoots& roots, const HostRules& rules) {
  const std::string host(request[http::field::host]);
  if (!host_allowed(host, rules)) return;
  const Route route = route_of(std::string_view(request.target().data(), request.target().size()), roots);
  if (boost::beast::websocket::is_upgrade(request)) {
    if (request.find(http::field::origin) != request.end())
      (void)origin_allowed(std::string(request[http::field::origin]), host, rules);
    return;
  }
  switch (route.kind) {
    case RouteKind::file: return check_file(route);
    case RouteKind::job_report:
      if (route.job < 0) __builtin_trap();
      return;
    case RouteKind::rpc:
    case RouteKind::metrics:
    case RouteKind::bad_request:
    case RouteKind::not_found: return;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const WebRoots roots{default_web_root()};
  // A station bound to every address, with a reverse proxy's origin: the widest Host rules.
  static const HostRules rules{8080, "0.0.0.0", {"https://cmm-station-3.example"}};
  std::string_view bytes = cmm::fuzz::text_of(data, size);
  // Requests one after another on a kept-alive connection, as HttpSession reads them.
  while (!bytes.empty()) {
    http::request_parser<http::empty_body> parser;
    parser.header_limit(kHeaderLimit);
    parser.body_limit(0);
    boost::beast::error_code ec;
    const std::size_t used = parser.put(boost::asio::buffer(bytes.data(), bytes.size()), ec);
    if (ec || !parser.is_header_done() || used == 0) return 0;
    if (!parser.is_done()) {
      parser.put_eof(ec);
      if (ec) return 0;
    }
    handle(parser.get(), roots, rules);
    bytes.remove_prefix(used);
  }
  return 0;
}
