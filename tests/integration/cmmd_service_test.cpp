// cmmd as a service, the real binary over real sockets: the JSON-RPC protocol and its limits, access
// by role and token, a hundred clients polling while a job runs, and the lifecycle (SIGTERM mid-job,
// SIGHUP, a bad config, --check).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "daemon/client/rpc_client.hpp"
#include "daemon/client/rpc_error.hpp"
#include "notify_listener.hpp"
#include "rpc_exchange.hpp"
#include "tests/daemon/fresh_folder.hpp"
#include "tests/tools/run_command.hpp"

namespace cmm {
namespace {

using daemon::RpcClient;
using daemon::RpcClientError;
using daemon::RpcError;
using nlohmann::json;
using testing::closed_by_cmmd;
using testing::CmmdInstance;
using testing::error_of;
using testing::next_reply;
using testing::request_reply;
constexpr auto tokens = testing::observer_and_operator_tokens;
namespace rpc_code = daemon::rpc_code;

const std::string kObserverToken = "observer-token-0123456789";
const std::string kOperatorToken = "operator-token-0123456789";
const std::string kCmmd = CMMD_BINARY_DIR "/daemon/cmmd";

// The next line of cmmd's log (stderr, read with the ready line) that contains `text`; lines before it are skipped.
std::string log_line_containing(testing::ChildProcess& cmmd, const std::string& text, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    std::string line = cmmd.read_line(std::max(left, 0.001));
    if (line.find(text) != std::string::npos) return line;
  }
}

void write_config(const std::filesystem::path& file, const json& config) {
  std::ofstream out(file);
  out << config.dump(1) << "\n";
  ASSERT_TRUE(out.flush()) << file;
}

// ---------------------------------------------------------------------------------------------
// Protocol

TEST(CmmdProtocol, AnswersMalformedMistypedAndUnknownRequestsAndStaysUp) {
  const auto dir = daemon::fresh_folder("service-protocol");
  CmmdInstance cmmd(dir, {{"driver", "sim"}});
  cmmd.start();
  RpcClient client = cmmd.client();

  json r = request_reply(client, R"({"jsonrpc": "2.0", "id": 1, "method": "server.info")");  // cut short
  EXPECT_EQ(r["error"]["code"], rpc_code::parse_error) << r;
  EXPECT_TRUE(r["id"].is_null()) << r;
  EXPECT_TRUE(r["error"]["data"]["byte"].is_number()) << r;
  r = request_reply(client, R"({"jsonrpc": "2.0", "id": 2, "method": 17})");
  EXPECT_EQ(r["error"]["code"], rpc_code::invalid_request) << r;
  r = request_reply(client, R"({"jsonrpc": "2.0", "id": 3, "method": "machine.fly"})");
  EXPECT_EQ(r["error"]["code"], rpc_code::method_not_found) << r;
  EXPECT_EQ(r["error"]["data"]["method"], "machine.fly") << r;
  EXPECT_EQ(r["id"], 3);

  // Wrong types and bad fields: −32602 with the JSON Pointer of the field.
  const std::string sha = "sha256:" + std::string(64, '0');
  const std::vector<std::pair<std::string, json>> bad_params = {
      {"job.get", {{"job", "1"}}},
      {"job.result", {{"job", 1.5}}},
      {"job.resume", {{"job", 1}, {"reregister", "yes"}}},
      {"job.submit", {{"model", 5}}},
      {"job.submit", {{"model", "http://example.com/part.stl"}}},
      {"job.submit", {{"model", sha}, {"delta_mm", "0.2"}}},
      {"job.submit", {{"model", sha}, {"spacing_mm", -1}}},
      {"job.submit", {{"model", sha}, {"colour", "red"}}},
      {"job.submit", {{"model", sha}}},
      {"job.submit",
       {{"model", sha},
        {"registration",
         {{"measure_plate",
           {{"scan_corners", {{{"id", 1}, {"scan", {0, 0, "z"}}}}}, {"rough_machine", json::array()}}}}}}},
      {"model.upload", {{"name", 5}, {"size", 3}, {"offset", 0}, {"sha256", std::string(64, '0')}, {"data", "YWJj"}}},
      {"model.upload", {{"name", "part.txt"}, {"size", 3}, {"offset", 0}, {"sha256", std::string(64, '0')}, {"data", "YWJj"}}},
      {"model.upload", {{"name", "part.ply"}, {"size", 3}, {"offset", 0}, {"sha256", "abc"}, {"data", "YWJj"}}},
      {"model.upload", {{"name", "part.ply"}, {"size", 3}, {"offset", 0}, {"sha256", std::string(64, '0')}, {"data", "YWJ"}}},
      {"model.upload", {{"name", "part.ply"}, {"size", -3}, {"offset", 0}, {"sha256", std::string(64, '0')}, {"data", ""}}},
  };
  const std::vector<std::string> paths = {"/job",           "/job",     "/reregister", "/model", "/model",
                                          "/delta_mm",      "/spacing_mm", "/colour",  "/registration",
                                          "/registration/measure_plate/scan_corners/0/scan/2",
                                          "/name",          "/name",    "/sha256",     "/data",  "/size"};
  ASSERT_EQ(bad_params.size(), paths.size());
  for (std::size_t i = 0; i < bad_params.size(); ++i) {
    const auto& [method, params] = bad_params[i];
    const RpcError e = error_of(client, method, params);
    EXPECT_EQ(e.code(), rpc_code::invalid_params) << method << " " << params << ": " << e.what();
    EXPECT_EQ(e.data().value("path", "?"), paths[i]) << method << " " << params << ": " << e.data();
  }
  // Well-formed but naming what is not there.
  const RpcError no_job = error_of(client, "job.get", {{"job", 99}});
  EXPECT_EQ(no_job.code(), rpc_code::not_found) << no_job.what();
  EXPECT_EQ(no_job.data()["job"], 99) << no_job.data();
  EXPECT_EQ(error_of(client, "job.submit", {{"model", sha}, {"registration", testing::sample_measure_plate(dir / "scan")}})
                .code(),
            rpc_code::not_found);

  // A batch: one array back with a reply per request, none for the notification, an error entry for
  // the entry that is no request.
  r = request_reply(client, R"([{"jsonrpc": "2.0", "id": 10, "method": "server.info"},
                                {"jsonrpc": "2.0", "method": "machine.status"},
                                {"jsonrpc": "2.0", "id": 11, "method": "job.list"},
                                {"jsonrpc": "2.0", "id": 12, "method": "job.get", "params": {"job": "x"}},
                                42])"_json.dump());
  ASSERT_TRUE(r.is_array()) << r;
  ASSERT_EQ(r.size(), 4u) << r;
  std::map<std::string, json> by_id;
  for (const json& entry : r) by_id[entry["id"].dump()] = entry;
  EXPECT_EQ(by_id["10"]["result"]["name"], "cmmd") << r;
  EXPECT_TRUE(by_id["11"]["result"]["jobs"].is_array()) << r;
  EXPECT_EQ(by_id["12"]["error"]["code"], rpc_code::invalid_params) << r;
  EXPECT_EQ(by_id["null"]["error"]["code"], rpc_code::invalid_request) << r;
  r = request_reply(client, "[]");
  EXPECT_EQ(r["error"]["code"], rpc_code::invalid_request) << r;

  // A notification gets no reply: the next line is the reply to the request after it.
  client.send_raw(R"({"jsonrpc": "2.0", "method": "job.list"})" "\n");
  r = request_reply(client, R"({"jsonrpc": "2.0", "id": 20, "method": "server.info"})");
  EXPECT_EQ(r["id"], 20) << r;
  // Nor does a batch of notifications only.
  client.send_raw(R"([{"jsonrpc": "2.0", "method": "job.list"}, {"jsonrpc": "2.0", "method": "server.info"}])" "\n");
  r = request_reply(client, R"({"jsonrpc": "2.0", "id": 22, "method": "server.info"})");
  EXPECT_EQ(r["id"], 22) << r;
  // Blank lines and \r\n are fine.
  r = request_reply(client, "\n  \r\n" R"({"jsonrpc": "2.0", "id": 21, "method": "server.info"})" "\r");
  EXPECT_EQ(r["id"], 21) << r;

  RpcClient next = cmmd.client();
  EXPECT_EQ(next.call("server.info")["role"], "operator");
  EXPECT_EQ(cmmd.terminate(), 0);
}

TEST(CmmdProtocol, ClosesAnOversizedAndAHalfSentRequestAndServesTheNextClient) {
  const auto dir = daemon::fresh_folder("service-limits");
  CmmdInstance cmmd(dir, {{"driver", "sim"}}, {{"server", {{"max_request_bytes", 1024}, {"idle_timeout_s", 0.5}}}});
  cmmd.start();

  RpcClient big = cmmd.tcp_client();
  const json r = request_reply(
      big, json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", "server.info"}, {"params", {{"pad", std::string(2000, 'x')}}}}
               .dump());
  EXPECT_EQ(r["error"]["code"], rpc_code::request_too_large) << r;
  EXPECT_EQ(r["error"]["data"]["max_request_bytes"], 1024) << r;
  EXPECT_TRUE(closed_by_cmmd(big, 30));

  // Just under the limit is fine.
  RpcClient fits = cmmd.tcp_client();
  const std::string pad(900, 'x');
  EXPECT_EQ(fits.call("server.info", {{"pad", pad}})["name"], "cmmd");

  // A connection that says nothing at all is not idle in that sense: it outlives the idle timeout below.
  RpcClient quiet = cmmd.client();
  // Half a request, then silence: closed after idle_timeout_s, long before the test's deadline.
  RpcClient half = cmmd.client();
  half.send_raw(R"({"jsonrpc": "2.0", "id": 1, "meth)");
  EXPECT_TRUE(closed_by_cmmd(half, 30));
  // Half a request, then the client goes away.
  {
    RpcClient gone = cmmd.tcp_client();
    gone.send_raw(R"({"jsonrpc": "2.0", "id": 1, "method": "server.in)");
  }

  RpcClient next = cmmd.tcp_client();
  EXPECT_EQ(next.call("server.info")["name"], "cmmd");
  EXPECT_EQ(quiet.call("server.info")["name"], "cmmd");
  EXPECT_EQ(cmmd.terminate(), 0);
}

// ---------------------------------------------------------------------------------------------
// Access

TEST(CmmdAccess, TcpNeedsATokenObserversWatchOperatorsMoveAndTheUnixSocketIsOperator) {
  const auto dir = daemon::fresh_folder("service-access");
  CmmdInstance cmmd(dir, {{"driver", "sim"}}, {{"server", {{"tokens", tokens(kObserverToken, kOperatorToken)}}}});
  cmmd.start();

  RpcClient anonymous = cmmd.tcp_client();
  EXPECT_EQ(anonymous.call("server.info")["role"], "none");
  RpcError e = error_of(anonymous, "machine.status");
  EXPECT_EQ(e.code(), rpc_code::unauthorized) << e.what();
  EXPECT_EQ(e.data()["needed"], "observer");
  EXPECT_EQ(error_of(anonymous, "job.list").code(), rpc_code::unauthorized);
  EXPECT_EQ(error_of(anonymous, "server.subscribe", {{"topics", {"job"}}}).code(), rpc_code::unauthorized);
  EXPECT_EQ(error_of(anonymous, "server.auth", {{"token", "operator-token-0123456780"}}).code(), rpc_code::auth_failed);
  EXPECT_EQ(error_of(anonymous, "server.auth", {{"token", ""}}).code(), rpc_code::auth_failed);
  EXPECT_EQ(error_of(anonymous, "machine.status").code(), rpc_code::unauthorized);  // still none

  RpcClient observer = cmmd.tcp_client();
  EXPECT_EQ(observer.call("server.auth", {{"token", kObserverToken}})["role"], "observer");
  EXPECT_EQ(observer.call("machine.status")["driver"], "sim");
  EXPECT_TRUE(observer.call("job.list")["jobs"].is_array());
  for (const char* method : {"machine.home", "job.submit", "model.upload", "machine.abort", "job.cancel"}) {
    e = error_of(observer, method, {{"job", 1}});
    EXPECT_EQ(e.code(), rpc_code::unauthorized) << method << ": " << e.what();
    EXPECT_EQ(e.data()["needed"], "operator") << method;
  }
  EXPECT_EQ(observer.call("machine.stop"), json::object()) << "a stop is always safe: observers may stop";
  // A failed auth leaves the observer an observer.
  EXPECT_EQ(error_of(observer, "server.auth", {{"token", "not-a-token-0123456789"}}).code(), rpc_code::auth_failed);
  EXPECT_EQ(observer.call("server.info")["role"], "observer");

  RpcClient operator_client = cmmd.tcp_client();
  EXPECT_EQ(operator_client.call("server.auth", {{"token", kOperatorToken}})["role"], "operator");
  EXPECT_TRUE(operator_client.call("machine.home", json::object(), 120).contains("position"));
  // The check is the role, not the params: an operator gets to the params check.
  EXPECT_EQ(error_of(operator_client, "job.submit", {{"model", 5}}).code(), rpc_code::invalid_params);

  // The Unix socket is operator without server.auth; its file is rw for owner and group only.
  RpcClient local = cmmd.client();
  EXPECT_EQ(local.call("server.info")["role"], "operator");
  EXPECT_TRUE(local.call("machine.home", json::object(), 120).contains("position"));
  struct stat st {};
  ASSERT_EQ(::stat((dir / "run" / "cmmd.sock").c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 07777, 0660u) << std::oct << (st.st_mode & 07777);
  EXPECT_EQ(cmmd.terminate(), 0);
}

TEST(CmmdAccess, RefusesToListenBeyondLoopbackWithoutTokens) {
  const auto dir = daemon::fresh_folder("service-bind");
  CmmdInstance open(dir / "open", {{"driver", "sim"}}, {{"server", {{"tcp_bind", "0.0.0.0"}}}});
  const std::string config = (dir / "open" / "cmmd.json").string();
  for (const std::string& flags : {std::string(), std::string(" --check")}) {
    const auto r = cmm::test::run_command("timeout 60 " + kCmmd + " --config " + config + flags);
    EXPECT_EQ(r.exit_code, 2) << flags << ": " << r.output;
    EXPECT_NE(r.output.find("/server/tcp_bind"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("loopback"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("tokens"), std::string::npos) << r.output;
  }
  // With tokens the same bind is served, and a TCP client starts with no role.
  CmmdInstance guarded(dir / "guarded", {{"driver", "sim"}},
                       {{"server", {{"tcp_bind", "0.0.0.0"}, {"tokens", tokens(kObserverToken, kOperatorToken)}}}});
  guarded.start();
  RpcClient client = guarded.tcp_client();
  EXPECT_EQ(client.call("server.info")["role"], "none");
  EXPECT_EQ(guarded.terminate(), 0);
}

// ---------------------------------------------------------------------------------------------
// Load

TEST(CmmdLoad, AHundredClientsPollingWhileAJobRunsAreAllAnswered) {
  const auto dir = daemon::fresh_folder("service-load");
  CmmdInstance cmmd(dir / "cmmd", testing::timed_sim_block(50));
  cmmd.start();
  RpcClient submitter = cmmd.client();
  const int job = testing::submit_quick_job(submitter, dir / "scan");

  constexpr int kClients = 100;
  std::mutex mutex;
  std::vector<std::string> errors;
  std::atomic<int> answers{0}, saw_probing{0}, saw_done{0};
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(10);
  std::vector<std::thread> clients;
  for (int i = 0; i < kClients; ++i) {
    clients.emplace_back([&, i] {
      try {
        // Half over TCP, half over the Unix socket; each waits for a job notification between polls.
        RpcClient c = i % 2 == 0 ? cmmd.operator_tcp_client() : cmmd.client();
        c.call("server.subscribe", {{"topics", {"job", "machine"}}});
        bool probing = false;
        for (;;) {
          const json record = c.call("job.get", {{"job", job}}, 60);
          const json status = c.call("machine.status", json::object(), 60);
          answers += 2;
          if (!status.contains("link")) throw std::runtime_error("machine.status without link: " + status.dump());
          const std::string state = record.at("state");
          probing = probing || state == "probing";
          if (state == "done" || state == "failed" || state == "cancelled") {
            if (state == "done") ++saw_done;
            else throw std::runtime_error("job ended " + state + ": " + record.dump());
            break;
          }
          if (std::chrono::steady_clock::now() > deadline) throw std::runtime_error("job still " + state);
          c.wait_notification(0.2);
        }
        if (probing) ++saw_probing;
      } catch (const std::exception& e) {
        std::lock_guard lock(mutex);
        errors.push_back("client " + std::to_string(i) + ": " + e.what());
      }
    });
  }
  for (std::thread& t : clients) t.join();
  for (const std::string& e : errors) ADD_FAILURE() << e;
  EXPECT_EQ(saw_done.load(), kClients);
  EXPECT_GT(saw_probing.load(), 0) << "no client polled while the job probed";
  EXPECT_GE(answers.load(), 4 * kClients);
  EXPECT_EQ(submitter.call("job.get", {{"job", job}})["state"], "done");
  EXPECT_EQ(cmmd.terminate(), 0);
}

// ---------------------------------------------------------------------------------------------
// Lifecycle

TEST(CmmdLifecycle, SigtermMidJobExitsZeroAndTheRestartedDaemonHasItInterruptedAndResumable) {
  const auto dir = daemon::fresh_folder("service-sigterm");
  CmmdInstance cmmd(dir / "cmmd", testing::timed_sim_block(50));
  cmmd.start();
  int job = 0;
  {
    RpcClient client = cmmd.client();
    job = testing::submit_quick_job(client, dir / "scan");
    testing::wait_for_job(client, job, {"probing"}, 600);
    // Mid-job means touches made and touches to come: SIGTERM after the first job.touch.
    testing::wait_for_notification(client, "job.touch", [](const json& n) { return n["method"] == "job.touch"; }, 300);
  }
  EXPECT_EQ(cmmd.terminate(), 0);
  EXPECT_FALSE(std::filesystem::exists(dir / "cmmd" / "run" / "cmmd.sock")) << "the socket is left behind";
  EXPECT_FALSE(testing::journal_touch_ids(cmmd.job_folder(job)).empty()) << "the touches made are kept";

  cmmd.start();
  RpcClient client = cmmd.client();
  const json jobs = client.call("job.list")["jobs"];
  ASSERT_EQ(jobs.size(), 1u) << jobs;
  EXPECT_EQ(jobs[0]["id"], job) << jobs;
  EXPECT_EQ(jobs[0]["state"], "interrupted") << jobs;
  EXPECT_FALSE(jobs[0]["reason"].get<std::string>().empty()) << jobs;
  client.call("job.resume", {{"job", job}});
  const json done = testing::wait_for_job(client, job, {"done"}, 900);
  EXPECT_EQ(done["state"], "done") << done;
  // Resumed, not started over: the journal has each planned touch once, the ones before the stop included.
  std::vector<int> ids = testing::journal_touch_ids(cmmd.job_folder(job));
  EXPECT_EQ(static_cast<int>(ids.size()), done["progress"]["total"].get<int>()) << done;
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(std::adjacent_find(ids.begin(), ids.end()), ids.end()) << "a touch made twice";
  EXPECT_EQ(cmmd.terminate(), 0);
}

TEST(CmmdLifecycle, ABadConfigExitsTwoNamingEveryProblemAndCheckValidatesWithoutStarting) {
  const auto dir = daemon::fresh_folder("service-config");
  const json bad = {{"server", {{"tcp_port", 70000}, {"unix_mode", "rw"}, {"tokens", {{{"token", "short"}}}}, {"colour", 1}}},
                    {"log", {{"level", "loud"}}},
                    {"machine", {{"driver", "teleport"}}},
                    {"job", {{"delta_mm", 99}}},
                    {"state_dir", "state"},
                    {"runtime_dir", "run"},
                    {"extra", true}};
  write_config(dir / "bad.json", bad);
  for (const std::string& flags : {std::string(), std::string(" --check")}) {
    const auto r = cmm::test::run_command("timeout 60 " + kCmmd + " --config " + (dir / "bad.json").string() + flags);
    EXPECT_EQ(r.exit_code, 2) << flags << ": " << r.output;
    for (const char* path : {"/server/tcp_port", "/server/unix_mode", "/server/tokens/0/token", "/server/colour",
                             "/log/level", "/machine", "/job/delta_mm", "/extra"})
      EXPECT_NE(r.output.find(path), std::string::npos) << flags << ": " << path << " not named in:\n" << r.output;
    EXPECT_NE(r.output.find("bad.json"), std::string::npos) << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "state")) << "a refused config must not create the state folder";

  const auto missing = cmm::test::run_command(kCmmd + " --check --config " + (dir / "none.json").string());
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("none.json"), std::string::npos) << missing.output;
  {
    std::ofstream(dir / "not_json.json") << "{\"server\": ";
  }
  const auto torn = cmm::test::run_command(kCmmd + " --check --config " + (dir / "not_json.json").string());
  EXPECT_EQ(torn.exit_code, 2) << torn.output;
  EXPECT_NE(torn.output.find("not valid JSON"), std::string::npos) << torn.output;

  // A good config: --check says so and exits without creating the state folder or the socket.
  CmmdInstance good(dir / "good", {{"driver", "sim"}});
  const auto valid = cmm::test::run_command("timeout 60 " + kCmmd + " --check --config " + (dir / "good" / "cmmd.json").string());
  EXPECT_EQ(valid.exit_code, 0) << valid.output;
  EXPECT_NE(valid.output.find("cmmd.json: valid"), std::string::npos) << valid.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "good" / "state"));
  EXPECT_FALSE(std::filesystem::exists(dir / "good" / "run" / "cmmd.sock"));

  const auto shipped = cmm::test::run_command(kCmmd + " --check --config " CMMD_SOURCE_DIR "/config/cmmd.json");
  EXPECT_EQ(shipped.exit_code, 0) << shipped.output;
  EXPECT_NE(shipped.output.find("valid"), std::string::npos) << shipped.output;
}

TEST(CmmdLifecycle, SighupAppliesNewTokensAndLogLevelAndABrokenFileKeepsCmmdRunning) {
  const auto dir = daemon::fresh_folder("service-sighup");
  const std::string old_operator = "old-operator-token-0123", new_operator = "new-operator-token-0123";
  CmmdInstance cmmd(dir, {{"driver", "sim"}}, {{"server", {{"tokens", tokens(kObserverToken, old_operator)}}}});
  // systemd's notify socket tells when a reload is through: READY=1 after RELOADING=1.
  testing::NotifyListener manager(dir / "notify.sock");
  cmmd.start(testing::notify_launcher(manager, 0), true);
  manager.wait_for("READY=1", 60);
  const auto reload = [&] {
    cmmd.process().signal(SIGHUP);
    manager.wait_for("RELOADING=1", 60);
    manager.wait_for("READY=1", 60);
  };
  RpcClient before = cmmd.tcp_client();
  EXPECT_EQ(before.call("server.auth", {{"token", old_operator}})["role"], "operator");

  json next = cmmd.config();
  next["server"]["tokens"] = tokens(kObserverToken, new_operator);
  next["log"]["level"] = "info";
  write_config(dir / "cmmd.json", next);
  reload();
  // Logged at info, after the new level is set: at the old level (warn) it would not be written.
  const std::string reloaded = log_line_containing(cmmd.process(), "SIGHUP: reloaded", 10);
  EXPECT_NE(reloaded.find("log level info"), std::string::npos) << reloaded;
  RpcClient fresh = cmmd.tcp_client();
  EXPECT_EQ(error_of(fresh, "server.auth", {{"token", old_operator}}).code(), rpc_code::auth_failed);
  EXPECT_EQ(fresh.call("server.auth", {{"token", new_operator}})["role"], "operator");
  // A role already granted stays with its connection.
  EXPECT_EQ(before.call("machine.status")["driver"], "sim");

  {
    std::ofstream(dir / "cmmd.json") << "{\"server\": {\"tokens\": [";
  }
  reload();
  const std::string refused = log_line_containing(cmmd.process(), "SIGHUP: ", 10);
  EXPECT_NE(refused.find("refused, running on"), std::string::npos) << refused;
  EXPECT_NE(refused.find("not valid JSON"), std::string::npos) << refused;
  RpcClient after = cmmd.tcp_client();
  EXPECT_EQ(after.call("server.auth", {{"token", new_operator}})["role"], "operator");
  EXPECT_EQ(cmmd.client().call("server.info")["name"], "cmmd");
  EXPECT_EQ(cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
