// Who may move the machine, and that STOP always gets through (issue 33), on the real cmmd: a web
// page's HTTP to the JSON-RPC port is closed unread, TCP is operator only by a token (the station
// token, the same after a restart until it is rotated), a jog belongs to the client that started it,
// observers stop, and STOP reaches the machine over the dashboard, TCP, the Unix socket and MQTT
// while hundreds of idle and half-sent connections and a broker user's wrong tokens flood every door.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

#include <nlohmann/json.hpp>

#include "broker_process.hpp"
#include "cmmd_instance.hpp"
#include "daemon/client/mqtt_client.hpp"
#include "daemon/client/rpc_client.hpp"
#include "rpc_exchange.hpp"
#include "tests/daemon/fresh_folder.hpp"
#include "tests/tools/run_command.hpp"
#include "web_client.hpp"

namespace cmm {
namespace {

using nlohmann::json;
using daemon::RpcClient;
using daemon::RpcError;
namespace rpc_code = daemon::rpc_code;
using Clock = std::chrono::steady_clock;

const std::string kCmmctl = CMMD_BINARY_DIR "/daemon/cmmctl";
const std::string kJogLine =
    R"({"jsonrpc":"2.0","id":1,"method":"machine.jog","params":{"direction":[1,0,0],"distance_mm":5}})";

#if defined(CMMD_SANITIZED)
constexpr double kSlowdown = 4;  // ASan and UBSan: everything takes longer
#else
constexpr double kSlowdown = 1;
#endif

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double x_of(RpcClient& client) { return client.call("machine.status")["position"][0].get<double>(); }

// A plain TCP connection to 127.0.0.1:port that has sent `bytes` and is then held, as a slow client
// holds it; -1 when it could not connect.
int held_connection(int port, const std::string& bytes) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (fd < 0 || ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    if (fd >= 0) ::close(fd);
    return -1;
  }
  (void)!::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  return fd;
}

// Waits until no jog runs and returns how the last one ended.
// machine.status's last_jog once jog `id` has ended. The status stops listing a jog as soon as a stop
// is asked for, a moment before its thread records why it ended: so wait for that record, by id.
json last_jog_when_ended(RpcClient& client, int id, double timeout_s = 20) {
  const auto t0 = Clock::now();
  for (;;) {
    const json status = client.call("machine.status");
    if (status["jog"].is_null() && status["last_jog"].is_object() && status["last_jog"]["id"] == id)
      return status["last_jog"];
    if (since(t0) > timeout_s) throw std::runtime_error("the jog still runs: " + status.dump());
    client.wait_notification(0.05);  // a pause that also drains what a subscription sent
  }
}

TEST(CmmdAccess, HttpToTheJsonRpcPortIsClosedUnreadAndMovesNothing) {
  const auto dir = daemon::fresh_folder("access-http");
  // No deadline to authenticate within the test's waits: a connection closed here was closed for what it sent.
  testing::CmmdInstance cmmd(dir, {{"driver", "sim"}}, {{"server", {{"auth_timeout_s", 600}, {"idle_timeout_s", 600}}}});
  cmmd.start();
  RpcClient unix_client = cmmd.client();
  unix_client.call("machine.home", json::object(), 120);
  const json before = unix_client.call("machine.status");

  // What a page's <form enctype="text/plain" method="POST"> or fetch(…, {mode: "no-cors"}) sends.
  const std::string body = kJogLine + "\n";
  RpcClient page = cmmd.tcp_client();
  page.send_raw("POST / HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(cmmd.tcp_port()) +
                "\r\nOrigin: http://evil.example\r\nContent-Type: text/plain\r\nContent-Length: " +
                std::to_string(body.size()) + "\r\n\r\n" + body);
  EXPECT_TRUE(testing::closed_by_cmmd(page, 10)) << "the HTTP request was kept open";
  // Half a request line is enough: closed before its end arrives.
  RpcClient slow = cmmd.tcp_client();
  slow.send_raw("OPTIONS / HT");
  EXPECT_TRUE(testing::closed_by_cmmd(slow, 10));
  // The same JSON-RPC from a client on this host without a token: refused, loopback is no role.
  RpcClient bare = cmmd.tcp_client();
  const json refused = testing::request_reply(bare, kJogLine);
  EXPECT_EQ(refused["error"]["code"], rpc_code::unauthorized) << refused;
  // Before authentication, anything that is not a JSON-RPC object or batch closes the connection.
  RpcClient text = cmmd.tcp_client();
  text.send_raw("hello\n");
  EXPECT_TRUE(testing::closed_by_cmmd(text, 10));
  // After it, a line that is not JSON gets −32700 as before, but HTTP still closes.
  RpcClient authed = cmmd.operator_tcp_client();
  EXPECT_EQ(testing::request_reply(authed, "hello")["error"]["code"], rpc_code::parse_error);
  authed.send_raw("Origin: http://evil.example\n");
  EXPECT_TRUE(testing::closed_by_cmmd(authed, 10));

  const json after = unix_client.call("machine.status");
  EXPECT_EQ(after["position"], before["position"]) << "the machine moved";
  EXPECT_TRUE(after["last_jog"].is_null()) << after;
  EXPECT_EQ(cmmd.terminate(), 0);
}

TEST(CmmdAccess, TcpIsOperatorOnlyByATokenAndTheStationTokenOutlivesARestartUntilRotated) {
  const auto dir = daemon::fresh_folder("access-token");
  testing::CmmdInstance cmmd(dir, {{"driver", "sim"}});
  cmmd.start();
  RpcClient anonymous = cmmd.tcp_client();
  EXPECT_EQ(anonymous.call("server.info")["role"], "none");
  EXPECT_EQ(testing::request_reply(anonymous, R"({"jsonrpc":"2.0","id":2,"method":"machine.home"})")["error"]["code"],
            rpc_code::unauthorized);
  const std::string token = cmmd.station_token();
  struct stat st {};
  ASSERT_EQ(::stat((dir / "state" / "operator.token").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u) << "readable by cmmd's group, for local tools";
  EXPECT_EQ(cmmd.operator_tcp_client().call("server.info")["role"], "operator");
  // cmmctl over TCP with the token file, as a local tool of cmmd's group runs it.
  const std::string tcp = " --endpoint tcp://127.0.0.1:" + std::to_string(cmmd.tcp_port());
  const auto status = cmm::test::run_command(kCmmctl + tcp + " --token-file " + (dir / "state" / "operator.token").string() + " home");
  EXPECT_EQ(status.exit_code, 0) << status.output;
  const auto wrong = cmm::test::run_command(kCmmctl + tcp + " --token not-the-station-token-0123 home");
  EXPECT_NE(wrong.exit_code, 0) << wrong.output;
  EXPECT_NE(wrong.output.find("unknown token"), std::string::npos) << wrong.output;

  EXPECT_EQ(cmmd.terminate(), 0);
  cmmd.start();
  EXPECT_EQ(cmmd.station_token(), token) << "a restart keeps the token";
  EXPECT_EQ(cmmd.operator_tcp_client().call("server.info")["role"], "operator");

  const auto rotated = cmm::test::run_command(kCmmctl + " --endpoint unix:" + (dir / "run" / "cmmd.sock").string() + " rotate-token");
  EXPECT_EQ(rotated.exit_code, 0) << rotated.output;
  EXPECT_NE(rotated.output.find("#token=" + cmmd.station_token()), std::string::npos) << rotated.output;
  EXPECT_NE(cmmd.station_token(), token);
  RpcClient old = cmmd.tcp_client();
  try {
    old.call("server.auth", {{"token", token}});
    ADD_FAILURE() << "the rotated token still authenticates";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), rpc_code::auth_failed);
  }
  EXPECT_EQ(cmmd.operator_tcp_client().call("server.info")["role"], "operator");
  EXPECT_EQ(cmmd.terminate(), 0);
}

// Two operators, one jog: client B's renewals never keep client A's jog alive after A let go, and
// an observer (a dashboard without a token) stops an operator's jog.
TEST(CmmdAccess, ASecondOperatorCannotKeepAnothersJogAliveAndAnObserverStopsIt) {
  const auto dir = daemon::fresh_folder("access-jog");
  testing::CmmdInstance cmmd(dir, {{"driver", "sim"}});
  cmmd.start();
  RpcClient unix_client = cmmd.client();
  unix_client.call("machine.home", json::object(), 120);
  RpcClient a = cmmd.operator_tcp_client(), b = cmmd.operator_tcp_client();
  const double x0 = x_of(unix_client);
  // Homed at the travel box's far corner: every jog here goes toward -x, -y or -z.
  const json held = {{"direction", {-1, 0, 0}}, {"speed_mm_s", 5}, {"hold_s", 0.3}};
  const int jog = a.call("machine.jog", held)["jog"].get<int>();
  int refused = 0, taken = 0;
  // B holds its button, about 10 calls a second, for as long as A's jog runs; A let go at once.
  const auto t0 = Clock::now();
  for (json status = unix_client.call("machine.status"); status["jog"].is_object() && since(t0) < 5;
       status = unix_client.call("machine.status")) {
    try {
      b.call("machine.jog", held);
      ++taken;
    } catch (const RpcError& e) {
      EXPECT_EQ(e.code(), rpc_code::machine_busy) << e.what();
      ++refused;
    }
    b.wait_notification(0.1);  // the button's cadence
  }
  const double lasted = since(t0);
  const json ended = last_jog_when_ended(unix_client, jog);
  const double moved = x0 - x_of(unix_client);
  std::printf("B's calls while A's jog %d ran: %d refused, %d taken; it ended after %.2f s (%s), %.3f mm\n", jog, refused,
              taken, lasted, ended.dump().c_str(), moved);
  EXPECT_EQ(taken, 0) << "B renewed or replaced A's jog";
  EXPECT_EQ(ended["id"], jog);
  EXPECT_EQ(ended["reason"], "released (no machine.jog within hold_s)");
  EXPECT_LE(moved, 5 * (0.3 + 0.1) + 0.05) << "the jog ran on after its owner let go";

  // A step jog of A's, stopped by a dashboard that has no token: an observer.
  const int step = a.call("machine.jog", {{"direction", {0, -1, 0}}, {"distance_mm", 40}})["jog"].get<int>();
  testing::WebSocketClient observer(cmmd.http_port());
  EXPECT_EQ(observer.call("server.info")["role"], "observer");
  observer.call("machine.jog_stop");
  EXPECT_EQ(last_jog_when_ended(unix_client, step)["reason"], "stopped by machine.jog_stop");
  const int down = a.call("machine.jog", {{"direction", {0, 0, -1}}, {"distance_mm", 40}})["jog"].get<int>();
  observer.call("machine.stop");
  EXPECT_EQ(last_jog_when_ended(unix_client, down)["fault"], "Aborted");
  EXPECT_EQ(observer.error_of("machine.home").code(), rpc_code::unauthorized) << "an observer stops, nothing more";
  EXPECT_EQ(cmmd.terminate(), 0);
}

// STOP while every door is flooded: 256 half-sent HTTP requests and 256 idle WebSockets held on the
// dashboard's port, and a broker user with no token sending wrong tokens about 200 a second. Each
// STOP ends a running jog; its latency (connect, authenticate, stop, answered) is printed, and
// bounded in the Release build only.
TEST(CmmdAccess, StopGetsThroughFloodedDoorsOverTheDashboardTcpTheUnixSocketAndMqtt) {
  const auto dir = daemon::fresh_folder("access-flood");
  const std::map<std::string, std::string> users = {{"alpha", "alpha-pw"}, {"ops", "ops-pw"}, {"mallory", "mallory-pw"}};
  testing::BrokerProcess broker(dir / "broker", users);
  broker.start();
  testing::CmmdInstance cmmd(dir / "cmmd", {{"driver", "sim"}},
                             {{"station", "alpha"},
                              {"mqtt", {{"enabled", true}, {"broker", "127.0.0.1"}, {"port", broker.port()},
                                        {"username", "alpha"}, {"password", "alpha-pw"}}}});
  cmmd.start();
  RpcClient unix_client = cmmd.client();
  unix_client.call("machine.home", json::object(), 120);
  const std::string token = cmmd.station_token();

  // The MQTT flood: wrong tokens from mallory, each a machine.stop, until the test ends.
  std::atomic<bool> flooding{true};
  std::atomic<int> flood_sent{0};
  daemon::MqttConnect as_mallory;
  as_mallory.host = "127.0.0.1";
  as_mallory.port = broker.port();
  as_mallory.username = "mallory";
  as_mallory.password = "mallory-pw";
  as_mallory.client_id = "mallory-flood";
  std::atomic<int> flood_answered{0}, flood_throttled{0};
  daemon::MqttCallbacks on_mallory;
  daemon::MqttClient* mallory_client = nullptr;
  on_mallory.connected = [&] { mallory_client->subscribe("cmmd/clients/mallory/flood/reply", 0); };
  on_mallory.message = [&](const daemon::MqttMessage& m) {
    ++flood_answered;
    if (m.payload.find("retry_after_s") != std::string::npos) ++flood_throttled;
  };
  daemon::MqttClient mallory(as_mallory, on_mallory);
  mallory_client = &mallory;
  mallory.start();
  // Stopped and joined on the way out, an exception's way too.
  struct Stopper {
    std::atomic<bool>& flag;
    std::thread thread;
    ~Stopper() {
      flag = false;
      if (thread.joinable()) thread.join();
    }
  };
  Stopper flood{flooding, std::thread([&] {
    const auto t0 = Clock::now();
    for (int i = 0; flooding && since(t0) < 120; ++i) {
      daemon::MqttMessage m;
      m.topic = "cmmd/alpha/api/request/mallory";
      m.response_topic = "cmmd/clients/mallory/flood/reply";
      m.payload = R"({"jsonrpc":"2.0","id":1,"method":"machine.stop"})";
      m.user_properties.emplace_back("token", "wrong-token-" + std::to_string(i));
      if (mallory.connected() && mallory.publish(m)) ++flood_sent;
      std::this_thread::sleep_until(t0 + std::chrono::milliseconds(5 * (i + 1)));  // paced: ~200 a second
    }
  })};

  // The operator's cmmctl on the broker, linked before the flood: libmosquitto's loop uses select(),
  // which takes no descriptor past 1023, and the flood below holds some 800 in this process.
  daemon::StationAddress address;
  address.broker.host = "127.0.0.1";
  address.broker.port = broker.port();
  address.broker.username = "ops";
  address.broker.password = "ops-pw";
  address.station = "alpha";
  address.token = token;
  RpcClient ops = RpcClient::connect_station(address);

  // The connection flood on the dashboard's port, held open.
  std::vector<int> slow_http;
  const std::string partial = "GET / HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(cmmd.http_port()) + "\r\nX-Slow: 1";
  for (int i = 0; i < 256; ++i) slow_http.push_back(held_connection(cmmd.http_port(), partial));
  std::vector<std::unique_ptr<testing::WebSocketClient>> idle;
  for (int i = 0; i < 256; ++i) {
    try {
      idle.push_back(std::make_unique<testing::WebSocketClient>(cmmd.http_port()));
    } catch (const std::exception&) {
      // Refused or closed while the flood is on: the flood's loss, not the test's.
    }
  }
  for (int i = 0; i < 256; ++i) slow_http.push_back(held_connection(cmmd.tcp_port(), "{\"jsonrpc\":"));  // and on TCP

  // The flood is on: the station answers mallory's wrong tokens, throttled by now (what proves the flood
  // ran: how many were sent by the end depends on how fast the STOPs went, 100 at 200 a second in 0.5 s).
  const auto flood_start = Clock::now();
  while (flood_throttled < 20 && since(flood_start) < 30 * kSlowdown) unix_client.wait_notification(0.05);
  ASSERT_GE(flood_throttled.load(), 20) << "the MQTT flood never reached the station: " << flood_answered << " answered";

  std::map<std::string, double> latency_s;
  const auto stop_via = [&](const std::string& door, const std::function<void()>& stop) {
    // Homed at the travel box's far corner: -y has room for every door's jog of 30 mm stopped early.
    const int jog = unix_client.call("machine.jog", {{"direction", {0, -1, 0}}, {"distance_mm", 30}})["jog"].get<int>();
    const auto t0 = Clock::now();
    stop();
    latency_s[door] = since(t0);
    EXPECT_EQ(last_jog_when_ended(unix_client, jog)["fault"], "Aborted") << "STOP over " << door << " did not stop the jog";
  };
  stop_via("dashboard (a tab connecting now)", [&] {
    testing::WebSocketClient tab(cmmd.http_port(), {{"Origin", "http://127.0.0.1:" + std::to_string(cmmd.http_port())}});
    EXPECT_EQ(tab.call("server.auth", {{"token", token}})["role"], "operator");
    tab.call("machine.stop");
  });
  stop_via("tcp", [&] { cmmd.operator_tcp_client().call("machine.stop"); });
  stop_via("unix socket", [&] { cmmd.client().call("machine.stop"); });
  stop_via("mqtt (user ops)", [&] { ops.call("machine.stop"); });
  flooding = false;
  flood.thread.join();
  mallory.stop();
  for (const int fd : slow_http)
    if (fd >= 0) ::close(fd);

  std::printf("during the flood (%d wrong tokens sent over MQTT, %d answered, %d of them throttled; %zu WebSockets and "
              "%zu raw connections opened):\n",
              flood_sent.load(), flood_answered.load(), flood_throttled.load(), idle.size(), slow_http.size());
  for (const auto& [door, s] : latency_s) std::printf("  STOP over %-34s %.1f ms\n", door.c_str(), s * 1e3);
#if !defined(CMMD_SANITIZED) && defined(NDEBUG)  // a bound in the Release build only
  for (const auto& [door, s] : latency_s) EXPECT_LT(s, 1.0) << "STOP over " << door;
#endif
  EXPECT_EQ(cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
