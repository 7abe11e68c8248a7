// The dashboard's server in the real cmmd: files from the web root and Debian's three.js and
// Chart.js with their content types, no way out of a root, the Host and Origin checks, JSON-RPC
// over the WebSocket with the roles of docs/api.md (observer by loopback, operator only by a
// token), notifications, an oversized message, the reports' tokens (in a header, never in the URL),
// and TCP unharmed beside it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "daemon/client/rpc_error.hpp"
#include "rpc_exchange.hpp"
#include "tests/daemon/fresh_folder.hpp"
#include "tests/tools/run_command.hpp"
#include "web_client.hpp"

namespace cmm {
namespace {

namespace fs = std::filesystem;
using daemon::RpcError;
using nlohmann::json;
using testing::CmmdInstance;
using testing::http_request;
using testing::WebSocketClient;
using testing::WebSocketRefused;
namespace rpc_code = daemon::rpc_code;

const std::string kObserverToken = "observer-token-0123456789";
const std::string kOperatorToken = "operator-token-0123456789";

void write_file(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream out(file);
  out << text;
  ASSERT_TRUE(out.flush()) << file;
}

// A web root of the test's own (the real dashboard's files are not this test's subject) with a
// symlink that leads out of it.
json web_root_config(const fs::path& dir) {
  write_file(dir / "web" / "index.html", "<!doctype html><title>cmmd test</title>");
  write_file(dir / "web" / "js" / "app.js", "export const answer = 42;\n");
  write_file(dir / "secret.txt", "not for the browser");
  fs::create_symlink(dir / "secret.txt", dir / "web" / "escape.txt");
  return {{"http", {{"web_root", (dir / "web").string()}}}};
}

std::string read_token(const CmmdInstance& cmmd) { return cmmd.station_token(); }

TEST(CmmdWeb, ServesTheWebRootAndDebiansLibrariesAndNothingOutsideThem) {
  const fs::path dir = daemon::fresh_folder("web-files");
  CmmdInstance cmmd(dir / "cmmd", {{"driver", "sim"}}, web_root_config(dir));
  cmmd.start();
  const int port = cmmd.http_port();
  ASSERT_GT(port, 0);

  testing::HttpReply r = http_request(port, "GET", "/");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.header("content-type"), "text/html; charset=utf-8");
  EXPECT_EQ(r.header("cache-control"), "no-cache");
  EXPECT_EQ(r.header("x-content-type-options"), "nosniff");
  EXPECT_NE(r.body.find("cmmd test"), std::string::npos) << r.body;
  r = http_request(port, "GET", "/static/js/app.js");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.header("content-type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(r.body, "export const answer = 42;\n");

  // libjs-three and libjs-chart.js (scripts/setup), served as they are installed.
  const fs::path three = "/usr/share/javascript/three/build/three.module.js";
  ASSERT_TRUE(fs::exists(three)) << "libjs-three is not installed (scripts/setup)";
  r = http_request(port, "GET", "/lib/three/build/three.module.js");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.header("content-type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(r.body.size(), fs::file_size(fs::canonical(three)));
  r = http_request(port, "GET", "/lib/three/examples/jsm/controls/OrbitControls.js");
  EXPECT_EQ(r.status, 200);
  EXPECT_NE(r.body.find("OrbitControls"), std::string::npos);
  r = http_request(port, "HEAD", "/lib/chart.js/chart.min.js");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.header("content-length"), std::to_string(fs::file_size("/usr/share/javascript/chart.js/chart.min.js")));
  EXPECT_TRUE(r.body.empty());

  // No way out: "..", encoded or not, is refused; a symlink out of the root is not there.
  for (const char* target : {"/static/../../../etc/passwd", "/static/%2e%2e/%2E%2E/etc/passwd",
                             "/lib/three/..%2F..%2F..%2F..%2Fetc%2Fpasswd", "/lib/chart.js/../../../../etc/passwd"}) {
    r = http_request(port, "GET", target);
    EXPECT_EQ(r.status, 400) << target << ": " << r.body;
    EXPECT_EQ(r.body.find("root:"), std::string::npos) << target;
  }
  for (const char* target : {"/static/escape.txt", "/static/js", "/static/missing.js", "/etc/passwd", "/static/",
                             "/lib/three/"}) {
    r = http_request(port, "GET", target);
    EXPECT_EQ(r.status, 404) << target << ": " << r.body;
    EXPECT_EQ(r.body.find("not for the browser"), std::string::npos) << target;
  }
  EXPECT_EQ(http_request(port, "GET", "/static/%zz").status, 400);
  EXPECT_EQ(http_request(port, "POST", "/").status, 405);
  EXPECT_EQ(http_request(port, "GET", "/rpc").status, 426);

  // Host: a foreign name (DNS rebinding) or another port is refused, loopback names are served.
  r = http_request(port, "GET", "/", {{"Host", "evil.example:" + std::to_string(port)}});
  EXPECT_EQ(r.status, 403) << r.body;
  EXPECT_EQ(http_request(port, "GET", "/", {{"Host", "localhost:" + std::to_string(port + 1)}}).status, 403);
  EXPECT_EQ(http_request(port, "GET", "/", {{"Host", "localhost:" + std::to_string(port)}}).status, 200);

  // Reports: the job's report.html, a clear 404 before there is one.
  r = http_request(port, "GET", "/jobs/41/report");
  EXPECT_EQ(r.status, 404);
  EXPECT_NE(r.body.find("no job 41"), std::string::npos) << r.body;
  fs::create_directories(cmmd.job_folder(42));
  r = http_request(port, "GET", "/jobs/42/report");
  EXPECT_EQ(r.status, 404);
  EXPECT_NE(r.body.find("job 42 has no report yet"), std::string::npos) << r.body;
  write_file(cmmd.job_folder(42) / "report.html", "<!doctype html><title>report 42</title>");
  r = http_request(port, "GET", "/jobs/42/report");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.header("content-type"), "text/html; charset=utf-8");
  EXPECT_NE(r.body.find("report 42"), std::string::npos);
  EXPECT_EQ(cmmd.terminate(), 0);
}

TEST(CmmdWeb, TheWebSocketIsRefusedToForeignOriginsAndHosts) {
  const fs::path dir = daemon::fresh_folder("web-origin");
  CmmdInstance cmmd(dir / "cmmd", {{"driver", "sim"}},
                    {{"http", {{"allowed_origins", {"http://station.example:8080"}}}}});
  cmmd.start();
  const int port = cmmd.http_port();
  const std::string here = "127.0.0.1:" + std::to_string(port);
  const auto refused = [&](const testing::Headers& headers) {
    try {
      WebSocketClient ws(port, headers);
    } catch (const WebSocketRefused& e) {
      return e.status;
    }
    return 101;
  };
  EXPECT_EQ(refused({{"Origin", "http://evil.example"}}), 403);
  EXPECT_EQ(refused({{"Origin", "http://localhost:" + std::to_string(port)}}), 403);  // not the page's own Host
  EXPECT_EQ(refused({{"Origin", "null"}}), 403);
  EXPECT_EQ(refused({{"Host", "evil.example:" + std::to_string(port)}, {"Origin", "http://evil.example:" + std::to_string(port)}}), 403);
  EXPECT_EQ(refused({{"Host", "evil.example:" + std::to_string(port)}}), 403);
  // The page's own origin, an allowed one, and a client that is no browser (no Origin).
  EXPECT_EQ(refused({{"Origin", "http://" + here}}), 101);
  EXPECT_EQ(refused({{"Origin", "http://station.example:8080"}}), 101);
  EXPECT_EQ(refused({}), 101);
  WebSocketClient ws(port, {{"Origin", "http://" + here}});
  EXPECT_EQ(ws.call("server.info")["role"], "observer");
  EXPECT_EQ(cmmd.terminate(), 0);
}

TEST(CmmdWeb, JsonRpcOverTheWebSocketObservesUntilTheDashboardTokenAndGetsNotifications) {
  const fs::path dir = daemon::fresh_folder("web-rpc");
  CmmdInstance cmmd(dir / "cmmd", {{"driver", "sim"}});
  cmmd.start();
  WebSocketClient ws(cmmd.http_port());

  // Loopback alone gives an observer, never the operator.
  const json info = ws.call("server.info");
  EXPECT_EQ(info["role"], "observer");
  EXPECT_EQ(info["name"], "cmmd");
  EXPECT_TRUE(ws.call("job.list").contains("jobs"));
  EXPECT_EQ(ws.call("machine.status")["driver"], "sim");  // a blocking method, on the workers
  for (const char* method : {"machine.home", "server.dashboard", "job.cancel"}) {
    const RpcError e = ws.error_of(method, {{"job", 1}});
    EXPECT_EQ(e.code(), rpc_code::unauthorized) << method << ": " << e.what();
    EXPECT_EQ(e.data().value("needed", ""), "operator") << e.data();
  }
  EXPECT_EQ(ws.error_of("server.auth", {{"token", "not-the-token-0123456789"}}).code(), rpc_code::auth_failed);

  // The station token, from the state folder (0640), raises it to operator.
  const std::string token = read_token(cmmd);
  ASSERT_EQ(token.size(), 64u);
  EXPECT_EQ(ws.call("server.auth", {{"token", token}})["role"], "operator");
  const std::string url = ws.call("server.dashboard")["url"];
  EXPECT_EQ(url, "http://127.0.0.1:" + std::to_string(cmmd.http_port()) + "/#token=" + token);
  EXPECT_EQ(ws.call("machine.status")["driver"], "sim");

  // TCP is operator only by a token, the same station token.
  daemon::RpcClient tcp = cmmd.tcp_client();
  EXPECT_EQ(tcp.call("server.info")["role"], "none");
  EXPECT_EQ(tcp.call("server.auth", {{"token", token}})["role"], "operator");
  const auto ctl = cmm::test::run_command(std::string(CMMD_BINARY_DIR "/daemon/cmmctl --endpoint unix:") +
                                          (cmmd.folder() / "run" / "cmmd.sock").string() + " dashboard");
  EXPECT_EQ(ctl.exit_code, 0) << ctl.output;
  EXPECT_EQ(ctl.output, url + "\n");

  // A batch in one message, one array back.
  ASSERT_TRUE(ws.send_text(R"([{"jsonrpc":"2.0","id":"a","method":"server.info"},{"jsonrpc":"2.0","id":"b","method":"job.list"}])"));
  std::optional<json> batch = ws.receive();
  while (batch && batch->is_object() && !batch->contains("id")) batch = ws.receive();  // a notification
  ASSERT_TRUE(batch && batch->is_array()) << (batch ? batch->dump() : "closed");
  EXPECT_EQ(batch->size(), 2u);

  // Subscribed, it hears a job submitted over the Unix socket.
  EXPECT_EQ(ws.call("server.subscribe", {{"topics", {"job", "machine"}}})["topics"], json::array({"job", "machine"}));
  daemon::RpcClient local = cmmd.client();
  const json corners = testing::read_json_file(CMMD_SOURCE_DIR "/config/samples/case3_block.corners.json");
  const int job = testing::submit_job(local, CMMD_SOURCE_DIR "/config/samples/case3_block.ply",
                                      {{"registration", {{"corners", corners.at("corners")}}}, {"spacing_mm", 8}});
  const json n = ws.wait_notification("job.state of the new job", [job](const json& m) {
    return m.value("method", "") == "job.state" && m["params"].value("job", -1) == job;
  }, 60);
  EXPECT_TRUE(n["params"].contains("state")) << n;
  local.call("job.cancel", {{"job", job}});
  EXPECT_EQ(cmmd.terminate(), 0);  // with the WebSocket still open
}

TEST(CmmdWeb, AnOversizedMessageClosesItsConnectionAndNoOther) {
  const fs::path dir = daemon::fresh_folder("web-oversized");
  CmmdInstance cmmd(dir / "cmmd", {{"driver", "sim"}}, {{"server", {{"max_request_bytes", 65536}}}});
  cmmd.start();
  WebSocketClient big(cmmd.http_port()), bystander(cmmd.http_port());
  bystander.call("server.subscribe", {{"topics", {"job"}}});
  EXPECT_EQ(big.call("server.info")["role"], "observer");

  const std::string oversized = R"({"jsonrpc":"2.0","id":1,"method":"server.info","params":{"pad":")" +
                                std::string(100000, 'x') + R"("}})";
  big.send_text(oversized);  // cmmd may close before it has all of it: either way the next read ends
  std::optional<json> reply = big.receive();
  EXPECT_FALSE(reply) << reply->dump();
  EXPECT_EQ(big.close_code(), 1009);  // message too big

  EXPECT_EQ(bystander.call("server.info")["role"], "observer");
  EXPECT_EQ(cmmd.operator_tcp_client().call("server.info")["role"], "operator");
  WebSocketClient next(cmmd.http_port());
  const std::string fits = R"({"jsonrpc":"2.0","id":1,"method":"server.info","params":{"pad":")" + std::string(60000, 'x') + R"("}})";
  ASSERT_TRUE(next.send_text(fits));
  const std::optional<json> answered = next.receive();
  ASSERT_TRUE(answered);
  EXPECT_EQ((*answered)["result"]["role"], "observer");
  EXPECT_EQ(cmmd.terminate(), 0);
}

TEST(CmmdWeb, WithTokensTheWebSocketStartsWithNoRoleAndReportsNeedATokenNeverInTheUrl) {
  const fs::path dir = daemon::fresh_folder("web-tokens");
  CmmdInstance cmmd(dir / "cmmd", {{"driver", "sim"}},
                    {{"server", {{"tokens", testing::observer_and_operator_tokens(kObserverToken, kOperatorToken)}}}});
  write_file(dir / "cmmd" / "state" / "operator.token", std::string(64, 'a') + "\n");
  cmmd.start();
  EXPECT_FALSE(fs::exists(dir / "cmmd" / "state" / "operator.token")) << "a stale station token is removed";

  WebSocketClient ws(cmmd.http_port());
  EXPECT_EQ(ws.call("server.info")["role"], "none");
  EXPECT_EQ(ws.error_of("job.list").code(), rpc_code::unauthorized);
  EXPECT_EQ(ws.call("server.auth", {{"token", kObserverToken}})["role"], "observer");
  EXPECT_TRUE(ws.call("job.list").contains("jobs"));
  EXPECT_EQ(ws.error_of("machine.home").code(), rpc_code::unauthorized);
  EXPECT_EQ(ws.call("server.auth", {{"token", kOperatorToken}})["role"], "operator");
  EXPECT_EQ(ws.call("server.dashboard")["url"], "http://127.0.0.1:" + std::to_string(cmmd.http_port()) + "/");

  // Three wrong tokens close the connection, as on TCP (the same server.auth).
  WebSocketClient guesser(cmmd.http_port());
  for (int i = 0; i < 3; ++i) EXPECT_EQ(guesser.error_of("server.auth", {{"token", "wrong-" + std::to_string(i)}}).code(), rpc_code::auth_failed);
  EXPECT_FALSE(guesser.receive());
  EXPECT_EQ(guesser.close_code(), 1008);  // policy violation

  fs::create_directories(cmmd.job_folder(3));
  write_file(cmmd.job_folder(3) / "report.html", "<!doctype html><title>report 3</title>");
  const int port = cmmd.http_port();
  EXPECT_EQ(http_request(port, "GET", "/jobs/3/report").status, 401);
  EXPECT_EQ(http_request(port, "GET", "/jobs/3/report", {{"Authorization", "Bearer wrong-token"}}).status, 403);
  const testing::HttpReply report = http_request(port, "GET", "/jobs/3/report", {{"Authorization", "Bearer " + kObserverToken}});
  EXPECT_EQ(report.status, 200);
  EXPECT_NE(report.body.find("report 3"), std::string::npos);
  EXPECT_EQ(report.header("referrer-policy"), "no-referrer");
  // A token in the URL (browser history, proxy logs, a printed report's footer) is never taken, not
  // even a right one beside a right header.
  for (const testing::HttpReply& refused :
       {http_request(port, "GET", "/jobs/3/report?token=" + kObserverToken),
        http_request(port, "GET", "/jobs/3/report?token=" + kOperatorToken, {{"Authorization", "Bearer " + kObserverToken}})}) {
    EXPECT_EQ(refused.status, 400) << refused.body;
    EXPECT_EQ(refused.body.find("report 3"), std::string::npos);
    EXPECT_NE(refused.body.find("never taken in a URL"), std::string::npos) << refused.body;
  }
  // The dashboard's way: job.report over its authenticated WebSocket, which needs a role like any call.
  WebSocketClient page(port);
  EXPECT_EQ(page.error_of("job.report", {{"job", 3}}).code(), rpc_code::unauthorized);
  page.call("server.auth", {{"token", kObserverToken}});
  EXPECT_EQ(page.error_of("job.report", {{"job", 3}}).code(), rpc_code::not_found) << "job 3 is no job cmmd knows";
  EXPECT_EQ(cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
