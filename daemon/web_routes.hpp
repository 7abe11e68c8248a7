// What a dashboard request's target asks for (docs/api.md, Dashboard transport): a file of the web
// root or of Debian's JavaScript packages, a job's report, the JSON-RPC WebSocket, the Prometheus
// metrics, or nothing.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace cmm::daemon {

struct WebRoots {
  std::filesystem::path web_root;                                   // "/" and "/static/"
  std::filesystem::path three = "/usr/share/javascript/three";       // libjs-three, "/lib/three/"
  std::filesystem::path chart_js = "/usr/share/javascript/chart.js";  // libjs-chart.js, "/lib/chart.js/"
};

enum class RouteKind { file, job_report, rpc, metrics, not_found, bad_request };

struct Route {
  RouteKind kind = RouteKind::not_found;
  std::filesystem::path root;  // file: where `relative` is looked up (static_files.hpp: resolve_under)
  std::string relative;        // file: the decoded path below root
  bool web_root = false;       // file: one of the dashboard's own (Cache-Control: no-cache)
  int job = 0;                 // job_report
  std::string problem;         // bad_request: what is wrong, for the 400's text
};

// `target` as the request line has it ("/lib/three/build/three.module.js", "/jobs/7/report"). A
// report asked for with ?token= is a bad request.
Route route_of(std::string_view target, const WebRoots& roots);

}  // namespace cmm::daemon
