// The dashboard's routes, from a request target to what serves it.
#include "daemon/web_routes.hpp"

#include <charconv>
#include <optional>
#include <tuple>

#include "daemon/static_files.hpp"

namespace cmm::daemon {

namespace {

Route bad(std::string problem) {
  Route r;
  r.kind = RouteKind::bad_request;
  r.problem = std::move(problem);
  return r;
}

Route file(const std::filesystem::path& root, std::string relative, bool web_root) {
  Route r;
  r.kind = RouteKind::file;
  r.root = root;
  r.relative = std::move(relative);
  r.web_root = web_root;
  return r;
}

// Whether a query string ("a=1&token=x") has `key`, with a value or without.
bool query_has(std::string_view query, std::string_view key) {
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
    if (pair.substr(0, pair.find('=')) == key) return true;
  }
  return false;
}

bool starts_with(std::string_view text, std::string_view prefix) { return text.substr(0, prefix.size()) == prefix; }

}  // namespace

Route route_of(std::string_view target, const WebRoots& roots) {
  if (target.empty() || target.front() != '/') return bad("the request target must be a path starting with /");
  const std::size_t question = target.find('?');
  const std::string_view query = question == std::string_view::npos ? std::string_view() : target.substr(question + 1);
  const std::optional<std::string> decoded = percent_decode(target.substr(0, question));
  if (!decoded) return bad("malformed percent-encoding in the path");
  const std::string_view path = *decoded;

  if (path == "/" || path == "/index.html") return file(roots.web_root, "index.html", true);
  if (path == "/rpc" || path == "/metrics") {
    Route r;
    r.kind = path == "/rpc" ? RouteKind::rpc : RouteKind::metrics;
    return r;
  }
  for (const auto& [prefix, root, own] : {std::tuple{std::string_view("/static/"), &roots.web_root, true},
                                          std::tuple{std::string_view("/lib/three/"), &roots.three, false},
                                          std::tuple{std::string_view("/lib/chart.js/"), &roots.chart_js, false}})
    if (starts_with(path, prefix)) return file(*root, std::string(path.substr(prefix.size())), own);

  // /jobs/<id>/report: the id in digits only, so the folder name cannot be steered.
  constexpr std::string_view jobs = "/jobs/", report = "/report";
  if (path.size() > jobs.size() + report.size() && starts_with(path, jobs) && path.ends_with(report)) {
    const std::string_view digits = path.substr(jobs.size(), path.size() - jobs.size() - report.size());
    int id = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), id);
    if (!digits.empty() && ec == std::errc() && end == digits.data() + digits.size() && digits.front() != '-') {
      // Refused, not ignored: whoever built such a link learns why it stopped working, and a token
      // in a URL stays in browser history, proxy logs and a printed page's footer.
      if (query_has(query, "token"))
        return bad("a token is never taken in a URL: the dashboard opens reports over its own connection "
                   "(job.report); a script sends \"Authorization: Bearer <token>\"");
      Route r;
      r.kind = RouteKind::job_report;
      r.job = id;
      return r;
    }
  }
  return {};
}

}  // namespace cmm::daemon
