// The dashboard server's rules without a socket: URL paths to files (no "..", encoded or not, no
// symlink out of the root), content types, routes, the Host and Origin checks, the dashboard's URL,
// and cmmd.json's "http" block. The real server is in tests/integration/cmmd_web_test.cpp.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <fstream>

#include "daemon/daemon_config.hpp"
#include "daemon/dashboard_access.hpp"
#include "daemon/host_origin_check.hpp"
#include "daemon/static_files.hpp"
#include "daemon/web_routes.hpp"
#include "hal/description/json_fields.hpp"
#include "tests/daemon/fresh_folder.hpp"

namespace cmm::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

void write_file(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream(file) << text;
}

TEST(StaticFiles, PercentDecodingRefusesMalformedEscapesAndNul) {
  EXPECT_EQ(percent_decode("%2e%2E/a%20b+c"), "../a b+c");
  EXPECT_EQ(percent_decode("plain"), "plain");
  EXPECT_FALSE(percent_decode("%zz"));
  EXPECT_FALSE(percent_decode("abc%2"));
  EXPECT_FALSE(percent_decode("%"));
  EXPECT_FALSE(percent_decode("a%00b"));
}

TEST(StaticFiles, ResolvesOnlyRegularFilesInsideTheRoot) {
  const fs::path dir = fresh_folder("static-files");
  const fs::path root = dir / "web";
  write_file(root / "index.html", "<html>");
  write_file(root / "js" / "app.js", "1");
  write_file(dir / "secret.txt", "secret");
  write_file(dir / "web2" / "other.js", "2");
  fs::create_symlink(dir / "secret.txt", root / "escape.txt");   // out of the root
  fs::create_symlink(root / "js" / "app.js", root / "alias.js");  // inside it
  fs::create_symlink(dir, root / "up");                           // a folder link out

  const ResolvedFile index = resolve_under(root, "index.html");
  ASSERT_EQ(index.lookup, FileLookup::found);
  EXPECT_EQ(index.path, fs::canonical(root / "index.html"));
  EXPECT_EQ(resolve_under(root, "/js/app.js").lookup, FileLookup::found);
  EXPECT_EQ(resolve_under(root, "alias.js").lookup, FileLookup::found);

  EXPECT_EQ(resolve_under(root, "../secret.txt").lookup, FileLookup::bad_path);
  EXPECT_EQ(resolve_under(root, "js/../index.html").lookup, FileLookup::bad_path);  // ".." anywhere
  EXPECT_EQ(resolve_under(root, "..").lookup, FileLookup::bad_path);
  EXPECT_EQ(resolve_under(root, std::string("a\0b", 3)).lookup, FileLookup::bad_path);
  EXPECT_EQ(resolve_under(root, "escape.txt").lookup, FileLookup::not_found);
  EXPECT_EQ(resolve_under(root, "up/secret.txt").lookup, FileLookup::not_found);
  EXPECT_EQ(resolve_under(root, "up/web2/other.js").lookup, FileLookup::not_found);  // /web2 is not under /web
  EXPECT_EQ(resolve_under(root, "js").lookup, FileLookup::not_found);                // a folder: no listing
  EXPECT_EQ(resolve_under(root, "").lookup, FileLookup::not_found);
  EXPECT_EQ(resolve_under(root, "missing.js").lookup, FileLookup::not_found);
  EXPECT_EQ(resolve_under(dir / "no-such-root", "index.html").lookup, FileLookup::not_found);
}

TEST(StaticFiles, ContentTypesFollowTheExtensionWithCharsetForText) {
  EXPECT_EQ(content_type("index.html"), "text/html; charset=utf-8");
  EXPECT_EQ(content_type("three.module.js"), "text/javascript; charset=utf-8");
  EXPECT_EQ(content_type("chart.mjs"), "text/javascript; charset=utf-8");
  EXPECT_EQ(content_type("APP.JS"), "text/javascript; charset=utf-8");
  EXPECT_EQ(content_type("style.css"), "text/css; charset=utf-8");
  EXPECT_EQ(content_type("data.json"), "application/json");
  EXPECT_EQ(content_type("logo.svg"), "image/svg+xml");
  EXPECT_EQ(content_type("shot.png"), "image/png");
  EXPECT_EQ(content_type("part.ply"), "application/octet-stream");
  EXPECT_EQ(content_type("README"), "application/octet-stream");
}

TEST(StaticFiles, TheDefaultWebRootIsTheSourceTreesWhileItExists) {
  EXPECT_EQ(default_web_root(), fs::path(CMMD_SOURCE_DIR) / "daemon" / "web");
}

TEST(WebRoutes, MapsTargetsToRootsReportsAndTheWebSocket) {
  const WebRoots roots{.web_root = "/srv/web", .three = "/js/three", .chart_js = "/js/chart"};
  for (const char* index : {"/", "/index.html"}) {
    const Route r = route_of(index, roots);
    EXPECT_EQ(r.kind, RouteKind::file) << index;
    EXPECT_EQ(r.root, "/srv/web");
    EXPECT_EQ(r.relative, "index.html");
    EXPECT_TRUE(r.web_root);
  }
  Route r = route_of("/static/js/app.js?v=2", roots);
  EXPECT_EQ(r.kind, RouteKind::file);
  EXPECT_EQ(r.relative, "js/app.js");
  EXPECT_TRUE(r.web_root);
  r = route_of("/lib/three/examples/jsm/controls/OrbitControls.js", roots);
  EXPECT_EQ(r.root, "/js/three");
  EXPECT_EQ(r.relative, "examples/jsm/controls/OrbitControls.js");
  EXPECT_FALSE(r.web_root);
  r = route_of("/lib/chart.js/chart.min.js", roots);
  EXPECT_EQ(r.root, "/js/chart");
  EXPECT_EQ(r.relative, "chart.min.js");
  // Decoded before resolve_under sees it, which refuses the "..".
  r = route_of("/static/%2e%2e/%2E%2E/etc/passwd", roots);
  EXPECT_EQ(r.relative, "../../etc/passwd");
  EXPECT_EQ(resolve_under(r.root, r.relative).lookup, FileLookup::bad_path);

  r = route_of("/jobs/7/report?x=1", roots);
  EXPECT_EQ(r.kind, RouteKind::job_report);
  EXPECT_EQ(r.job, 7);
  // A token in a URL lands in history, proxy logs and a printed report's footer: never taken.
  for (const char* with_token : {"/jobs/7/report?x=1&token=ab%2Bc", "/jobs/7/report?token=", "/jobs/7/report?token"}) {
    r = route_of(with_token, roots);
    EXPECT_EQ(r.kind, RouteKind::bad_request) << with_token;
    EXPECT_NE(r.problem.find("never taken in a URL"), std::string::npos) << r.problem;
  }
  EXPECT_EQ(route_of("/jobs/7/report?tokens=1", roots).kind, RouteKind::job_report);
  for (const char* not_a_job : {"/jobs/x/report", "/jobs/-1/report", "/jobs//report", "/jobs/99999999999/report",
                                "/jobs/7/result", "/jobs/7", "/jobs/report"})
    EXPECT_EQ(route_of(not_a_job, roots).kind, RouteKind::not_found) << not_a_job;

  EXPECT_EQ(route_of("/rpc", roots).kind, RouteKind::rpc);
  EXPECT_EQ(route_of("/metrics", roots).kind, RouteKind::metrics);
  EXPECT_EQ(route_of("/rpc/x", roots).kind, RouteKind::not_found);
  EXPECT_EQ(route_of("/static", roots).kind, RouteKind::not_found);
  EXPECT_EQ(route_of("/etc/passwd", roots).kind, RouteKind::not_found);
  EXPECT_EQ(route_of("/%zz", roots).kind, RouteKind::bad_request);
  EXPECT_EQ(route_of("http://evil.example/", roots).kind, RouteKind::bad_request);
  EXPECT_EQ(route_of("", roots).kind, RouteKind::bad_request);
}

TEST(HostOriginCheck, TheHostMustNameALoopbackAddressLocalhostOrTheBindWithOurPort) {
  const HostRules rules{.port = 7621, .bind = "127.0.0.1", .allowed_origins = {}};
  for (const char* good : {"127.0.0.1:7621", "localhost:7621", "LocalHost:7621", "127.0.0.2:7621", "[::1]:7621"})
    EXPECT_TRUE(host_allowed(good, rules)) << good;
  // A foreign name (DNS rebinding points it at us), another port, no port, garbage.
  for (const char* bad : {"evil.example:7621", "localhost.evil.example:7621", "localhost", "localhost:7620",
                          "10.0.0.5:7621", "", ":7621", "127.0.0.1:", "127.0.0.1:abc", "127.0.0.1:7621:1",
                          "[::1", "[::1]x", "127.0.0.1:99999"})
    EXPECT_FALSE(host_allowed(bad, rules)) << bad;

  const HostRules any{.port = 7621, .bind = "0.0.0.0", .allowed_origins = {}};
  EXPECT_TRUE(host_allowed("192.168.1.20:7621", any));  // an address is never rebound
  EXPECT_FALSE(host_allowed("station.local:7621", any));
  const HostRules named{.port = 7621, .bind = "192.168.1.20", .allowed_origins = {"http://Station.local:7621", "https://cmm.example"}};
  EXPECT_TRUE(host_allowed("192.168.1.20:7621", named));
  EXPECT_FALSE(host_allowed("192.168.1.21:7621", named));
  EXPECT_TRUE(host_allowed("station.local:7621", named));
  EXPECT_TRUE(host_allowed("cmm.example", named));  // behind a proxy on https's default port
  EXPECT_FALSE(host_allowed("cmm.example:7621", named));
}

TEST(HostOriginCheck, TheOriginMustBeThePagesOwnOrAnAllowedOne) {
  const HostRules rules{.port = 7621, .bind = "127.0.0.1", .allowed_origins = {"http://station.local:7621/"}};
  EXPECT_TRUE(origin_allowed("http://127.0.0.1:7621", "127.0.0.1:7621", rules));
  EXPECT_TRUE(origin_allowed("HTTP://LOCALHOST:7621", "localhost:7621", rules));
  EXPECT_TRUE(origin_allowed("http://station.local:7621", "127.0.0.1:7621", rules));
  EXPECT_FALSE(origin_allowed("http://evil.example", "127.0.0.1:7621", rules));
  EXPECT_FALSE(origin_allowed("http://localhost:7621", "127.0.0.1:7621", rules));  // the page is not where it asks
  EXPECT_FALSE(origin_allowed("https://127.0.0.1:7621", "127.0.0.1:7621", rules));
  EXPECT_FALSE(origin_allowed("null", "127.0.0.1:7621", rules));  // a file:// page or a sandboxed frame
  EXPECT_FALSE(origin_allowed("http://127.0.0.1:7621", "", rules));
}

TEST(DashboardAccess, TheUrlNamesTheBindAddressAndCarriesTheTokenInItsFragment) {
  EXPECT_EQ(dashboard_url("127.0.0.1", 7621, "abc"), "http://127.0.0.1:7621/#token=abc");
  EXPECT_EQ(dashboard_url("0.0.0.0", 80, ""), "http://127.0.0.1:80/");
  EXPECT_EQ(dashboard_url("::1", 7621, ""), "http://[::1]:7621/");
  EXPECT_EQ(dashboard_url("localhost", 1, "t"), "http://localhost:1/#token=t");
}

std::vector<std::string> problems_of(const json& config) {
  try {
    daemon_config_from_json(config, "cmmd.json", "/etc/cmmd");
  } catch (const description::FieldError& e) {
    return e.lines();
  }
  return {};
}

bool names(const std::vector<std::string>& problems, const std::string& text) {
  return std::any_of(problems.begin(), problems.end(), [&](const std::string& p) { return p.find(text) != std::string::npos; });
}

TEST(HttpConfig, DefaultsAndOverrides) {
  const DaemonConfig defaults = daemon_config_from_json(json::object(), "cmmd.json", "/etc/cmmd");
  EXPECT_TRUE(defaults.http.enabled);
  EXPECT_EQ(defaults.http.port, 7621);
  EXPECT_TRUE(defaults.http.allowed_origins.empty());
  EXPECT_EQ(defaults.http.web_root, default_web_root());
  const DaemonConfig set = daemon_config_from_json(
      {{"http", {{"enabled", false}, {"port", 0}, {"allowed_origins", {"http://station.local:7621"}}, {"web_root", "web"}}}},
      "cmmd.json", "/etc/cmmd");
  EXPECT_FALSE(set.http.enabled);
  EXPECT_EQ(set.http.port, 0);
  EXPECT_EQ(set.http.allowed_origins, std::vector<std::string>{"http://station.local:7621"});
  EXPECT_EQ(set.http.web_root, fs::path("/etc/cmmd/web"));
  EXPECT_EQ(changes_needing_restart(defaults, set), std::vector<std::string>{"http"});
}

TEST(HttpConfig, EveryBadFieldIsNamedByItsPointer) {
  const auto problems = problems_of(
      {{"http", {{"port", 70000}, {"enabled", "yes"}, {"colour", 1}, {"allowed_origins", {"ftp://x", 5, "http://a/b", "http://ok:1"}}}}});
  for (const char* pointer : {"/http/port", "/http/enabled", "/http/colour", "/http/allowed_origins/0",
                              "/http/allowed_origins/1", "/http/allowed_origins/2"})
    EXPECT_TRUE(names(problems, pointer)) << pointer << " in " << ::testing::PrintToString(problems);
  EXPECT_FALSE(names(problems, "/http/allowed_origins/3")) << ::testing::PrintToString(problems);
  EXPECT_TRUE(names(problems_of({{"http", "on"}}), "/http")) << "not an object";
}

TEST(HttpConfig, TheDashboardBeyondLoopbackNeedsTokensLikeTcp) {
  const json open = {{"server", {{"tcp_bind", "0.0.0.0"}, {"tcp_enabled", false}}}};
  EXPECT_TRUE(names(problems_of(open), "/http/enabled")) << ::testing::PrintToString(problems_of(open));
  json off = open;
  off["http"] = {{"enabled", false}};
  EXPECT_TRUE(problems_of(off).empty()) << ::testing::PrintToString(problems_of(off));
  json guarded = open;
  guarded["server"]["tokens"] = {{{"token", "observer-token-0123456789"}, {"role", "observer"}}};
  EXPECT_TRUE(problems_of(guarded).empty()) << ::testing::PrintToString(problems_of(guarded));
}

}  // namespace
}  // namespace cmm::daemon
