// RpcServer over real sockets (an ephemeral TCP port and a Unix socket in the temp folder), talked
// to with RpcClient and raw bytes: framing, every limit of docs/api.md, access, notifications,
// many clients at once, and refusals at start.
#include "daemon/rpc_server.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <mutex>
#include <set>
#include <thread>

#include <asio/executor_work_guard.hpp>
#include <asio/post.hpp>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "daemon/client/rpc_client.hpp"

namespace cmm::daemon {
namespace {

using nlohmann::json;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

// Slow handlers wait here until the test opens it (never longer than 20 s, so a failing test ends).
class Gate {
 public:
  void open() {
    std::lock_guard lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }
  void pass() {
    std::unique_lock lock(mutex_);
    ++waiting_;
    changed_.notify_all();
    if (!changed_.wait_for(lock, std::chrono::seconds(20), [&] { return open_; }))
      throw std::runtime_error("gate never opened");
  }
  bool wait_for_waiting(int n) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, std::chrono::seconds(20), [&] { return waiting_ >= n; });
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = false;
  int waiting_ = 0;
};

bool eventually(const std::function<bool()>& condition, double timeout_s = 20) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::yield();
  }
  return true;
}

std::string fresh_socket_path() {
  static int counter = 0;
  const std::string path = ::testing::TempDir() + "cmmd-rpc-" + std::to_string(getpid()) + "-" + std::to_string(++counter) + ".sock";
  fs::remove(path);
  return path;
}

ServerOptions test_options() {
  ServerOptions options;
  options.tcp_port = 0;
  options.unix_path = fresh_socket_path();
  return options;
}

json request(const json& id, const std::string& method, const json& params = json::object()) {
  return {{"jsonrpc", "2.0"}, {"id", id}, {"method", method}, {"params", params}};
}

std::string line_of(const json& message) { return message.dump() + "\n"; }

// The rig's own operator token: a TCP client is a role only by a token.
const std::string kRigToken = "rig-operator-token-0123456789";

// An RpcServer on its own io thread, with a few methods to call.
class Rig {
 public:
  explicit Rig(ServerOptions options = test_options()) : unix_path(options.unix_path) {
    options.tokens.push_back({kRigToken, Role::operator_});
    dispatcher.add("echo", {Role::observer, Work::quick, [](const json& p, RpcContext&) { return p; }});
    dispatcher.add("admin.poke", {Role::operator_, Work::quick, [](const json&, RpcContext&) -> json { return "poked"; }});
    dispatcher.add("slow.echo", {Role::observer, Work::blocking, [](const json& p, RpcContext&) { return p; }});
    dispatcher.add("slow.wait", {Role::observer, Work::blocking, [this](const json& p, RpcContext&) {
                                   gate.pass();
                                   return p;
                                 }});
    dispatcher.add("whoami", {Role::none, Work::quick, [](const json&, RpcContext& ctx) -> json {
                                return {{"role", to_string(ctx.role())}, {"peer", ctx.peer()}};
                              }});
    dispatcher.add("plan.wait", {Role::observer, Work::planning, [this](const json& p, RpcContext&) {
                                   gate.pass();
                                   return p;
                                 }});
    // Runs until its connection closes (as a preview does whose client went away), at most 20 s.
    dispatcher.add("plan.until_closed", {Role::observer, Work::planning, [this](const json&, RpcContext& ctx) -> json {
                                           running = true;
                                           const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
                                           while (!ctx.closed() && std::chrono::steady_clock::now() < deadline)
                                             std::this_thread::yield();
                                           saw_closed = ctx.closed();
                                           return nullptr;
                                         }});
    dispatcher.add("slow.big", {Role::observer, Work::blocking, [](const json& p, RpcContext&) -> json {
                                  return std::string(p.at(0).get<std::size_t>(), 'x');
                                }});
    server.emplace(io, dispatcher, std::move(options));
    server->start();
    thread = std::thread([this] { io.run(); });
  }
  ~Rig() {
    gate.open();
    stop();
    guard.reset();
    thread.join();
  }

  void stop() {
    std::promise<void> done;
    asio::post(io, [&] {
      server->stop();
      done.set_value();
    });
    done.get_future().wait();
  }
  std::string tcp_endpoint() const { return "tcp://127.0.0.1:" + std::to_string(server->tcp_port()); }
  RpcClient raw_tcp() { return RpcClient::connect(tcp_endpoint(), 10); }  // role none
  RpcClient tcp() {  // operator, by the rig's token
    RpcClient client = raw_tcp();
    client.call("server.auth", {{"token", kRigToken}});
    return client;
  }
  RpcClient local() { return RpcClient::connect("unix:" + unix_path, 10); }

  std::string unix_path;
  Gate gate;
  std::atomic<bool> running{false}, saw_closed{false};
  asio::io_context io;
  asio::executor_work_guard<asio::io_context::executor_type> guard = asio::make_work_guard(io);
  RpcDispatcher dispatcher;
  std::optional<RpcServer> server;
  std::thread thread;
};

// The JSON-RPC error a call raised, or a failure when it raised none.
RpcError error_of(const std::function<void()>& call) {
  try {
    call();
  } catch (const RpcError& e) {
    return e;
  }
  ADD_FAILURE() << "no RpcError";
  return RpcError(0, "none");
}

json next_reply(RpcClient& client) {
  const auto line = client.read_line(20);
  if (!line) {
    ADD_FAILURE() << "no line within 20 s";
    return json();
  }
  return json::parse(*line);
}

// True once the server has closed the connection (every line before that is skipped).
bool closed_by_server(RpcClient& client) {
  try {
    while (client.read_line(20)) {
    }
    return false;  // 20 s of silence, still open
  } catch (const RpcClientError& e) {
    return std::string(e.what()).find("connection closed by cmmd") != std::string::npos;
  }
}

TEST(RpcServerTest, CallsOverTcpAndUnix) {
  Rig rig;
  auto tcp = rig.tcp();
  auto local = rig.local();
  EXPECT_EQ(tcp.call("echo", {{"x", 1}}), json({{"x", 1}}));
  EXPECT_EQ(local.call("slow.echo", {1, 2}), json({1, 2}));
  EXPECT_THAT(tcp.call("whoami").at("peer").get<std::string>(), HasSubstr("tcp://127.0.0.1:"));
  EXPECT_THAT(local.call("whoami").at("peer").get<std::string>(), HasSubstr("unix:" + rig.unix_path + " (pid "));
  EXPECT_EQ(rig.server->connection_count(), 2u);
}

TEST(RpcServerTest, MalformedJsonIsAnsweredAndTheConnectionStays) {
  Rig rig;
  auto client = rig.tcp();
  client.send_raw("{\"jsonrpc\": \"2.0\", \"method\": \"echo\", \"id\": 1\n");
  const json reply = next_reply(client);
  EXPECT_EQ(reply.at("error").at("code"), rpc_code::parse_error);
  EXPECT_TRUE(reply.at("id").is_null());
  EXPECT_EQ(client.call("echo", {{"still", "here"}}), json({{"still", "here"}}));
}

TEST(RpcServerTest, WrongTypesAreInvalidRequests) {
  Rig rig;
  auto client = rig.tcp();
  for (const char* bad : {R"({"jsonrpc": "2.0", "id": 1, "method": 5})", R"({"jsonrpc": "2.0", "id": 2, "method": "echo", "params": "x"})",
                                R"({"jsonrpc": "1.0", "id": 3, "method": "echo"})", R"({"jsonrpc": "2.0", "id": [4], "method": "echo"})"}) {
    SCOPED_TRACE(bad);
    client.send_raw(std::string(bad) + "\n");
    EXPECT_EQ(next_reply(client).at("error").at("code"), rpc_code::invalid_request);
  }
}

TEST(RpcServerTest, UnknownMethod) {
  Rig rig;
  auto client = rig.tcp();
  const RpcError e = error_of([&] { client.call("job.frobnicate"); });
  EXPECT_EQ(e.code(), rpc_code::method_not_found);
  EXPECT_EQ(e.data(), json({{"method", "job.frobnicate"}}));
}

TEST(RpcServerTest, FramingAcceptsCrLfSplitAndJoinedLines) {
  Rig rig;
  auto client = rig.tcp();
  const std::string one = request(1, "echo", {1}).dump(), two = request(2, "echo", {2}).dump();
  client.send_raw(one.substr(0, 10));
  client.send_raw(one.substr(10) + "\r\n\n   \r\n" + two + "\n");
  EXPECT_EQ(next_reply(client).at("result"), json({1}));
  EXPECT_EQ(next_reply(client).at("result"), json({2}));
}

TEST(RpcServerTest, Batches) {
  Rig rig;
  auto client = rig.tcp();
  client.send_raw("[]\n");
  const json empty = next_reply(client);
  EXPECT_EQ(empty.at("error").at("code"), rpc_code::invalid_request);

  // Notifications only: no reply at all, so the next line is the following call's.
  const json note = {{"jsonrpc", "2.0"}, {"method", "echo"}, {"params", {1}}};
  client.send_raw(line_of(json::array({note, note})) + line_of(request(7, "echo", {7})));
  EXPECT_EQ(next_reply(client).at("id"), 7);

  // A batch with a slow method runs on a worker, fast members included, and comes back whole.
  client.send_raw(line_of(json::array({request("a", "echo", {1}), note, request("b", "slow.echo", {2}), 5})));
  const json replies = next_reply(client);
  ASSERT_TRUE(replies.is_array()) << replies;
  ASSERT_EQ(replies.size(), 3u);
  EXPECT_EQ(replies[0].at("result"), json({1}));
  EXPECT_EQ(replies[1].at("result"), json({2}));
  EXPECT_EQ(replies[2].at("error").at("code"), rpc_code::invalid_request);
}

TEST(RpcServerTest, OversizedRequestIsAnsweredThenClosed) {
  ServerOptions options = test_options();
  options.max_request_bytes = 1024;
  Rig rig(options);

  // Exactly the limit (without the newline) is fine.
  json at_limit = request(1, "echo", {{"pad", ""}});
  at_limit["params"]["pad"] = std::string(1024 - at_limit.dump().size(), 'x');
  ASSERT_EQ(at_limit.dump().size(), 1024u);
  auto client = rig.tcp();
  client.send_raw(at_limit.dump() + "\r\n");
  EXPECT_EQ(next_reply(client).at("id"), 1);

  // One byte more, newline and all: −32002, then closed.
  at_limit["params"]["pad"] = at_limit["params"]["pad"].get<std::string>() + "x";
  client.send_raw(line_of(at_limit));
  const json reply = next_reply(client);
  EXPECT_EQ(reply.at("error").at("code"), rpc_code::request_too_large);
  EXPECT_EQ(reply.at("error").at("data"), json({{"max_request_bytes", 1024}}));
  EXPECT_TRUE(closed_by_server(client));

  // Without a newline the server does not wait for one: 64 KiB of a line are enough to refuse.
  auto endless = rig.tcp();
  endless.send_raw("[" + std::string(64 * 1024, ' '));
  EXPECT_EQ(next_reply(endless).at("error").at("code"), rpc_code::request_too_large);
  EXPECT_TRUE(closed_by_server(endless));
}

TEST(RpcServerTest, HalfALineThenSilenceIsClosedAfterTheIdleTimeout) {
  ServerOptions options = test_options();
  options.idle_timeout_s = 0.2;
  Rig rig(options);
  auto quiet = rig.local();  // connected first, sends nothing: idle, but not mid-request
  EXPECT_EQ(quiet.call("echo", {1}), json({1}));
  auto half = rig.tcp();
  half.send_raw(R"({"jsonrpc": "2.0", "method": "ec)");
  const auto start = std::chrono::steady_clock::now();
  EXPECT_TRUE(closed_by_server(half));
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(150));
  EXPECT_EQ(quiet.call("echo", {2}), json({2}));
}

TEST(RpcServerTest, TooManyConnectionsGetOneErrorLine) {
  ServerOptions options = test_options();
  options.max_connections = 3;
  options.max_unix_connections = 2;
  Rig rig(options);
  std::vector<RpcClient> clients;
  for (int i = 0; i < 3; ++i) {
    clients.push_back(rig.tcp());
    EXPECT_EQ(clients.back().call("echo", {i}), json({i}));
  }
  auto extra = rig.raw_tcp();  // all three authenticated: none is closed to make room
  const json refused = next_reply(extra);
  EXPECT_EQ(refused.at("error").at("code"), rpc_code::too_many_connections);
  EXPECT_EQ(refused.at("error").at("data"), json({{"max_connections", 3}}));
  EXPECT_TRUE(refused.at("id").is_null());
  EXPECT_TRUE(closed_by_server(extra));
  extra.close();  // the server keeps its end until the refused client has read the line and gone

  // The Unix socket has its own allowance: TCP clients filling theirs do not lock it out.
  auto local = rig.local(), second = rig.local();
  EXPECT_EQ(local.call("admin.poke"), "poked");
  EXPECT_EQ(second.call("echo", {7}), json({7}));
  const RpcError full = error_of([&] { RpcClient::connect("unix:" + rig.unix_path, 10).call("echo"); });
  EXPECT_EQ(full.code(), rpc_code::too_many_connections);
  EXPECT_EQ(full.data(), json({{"max_unix_connections", 2}}));

  // A freed place is taken again.
  clients.front().close();
  ASSERT_TRUE(eventually([&] { return rig.server->connection_count() <= 4; }));
  auto again = rig.tcp();
  EXPECT_EQ(again.call("echo", {9}), json({9}));
}

// A TCP connection that sends no complete request for idle_timeout_s and waits for no reply is
// closed unless it subscribed: idle connections cannot hold the connection allowance (issue 13, D5).
TEST(RpcServerTest, ASilentTcpConnectionIsClosedUnlessItSubscribedOrAwaitsAReply) {
  ServerOptions options = test_options();
  options.idle_timeout_s = 0.3;
  Rig rig(options);
  auto silent = rig.tcp();
  auto talked = rig.tcp();
  EXPECT_EQ(talked.call("echo", {1}), json({1}));
  auto subscriber = rig.tcp();
  subscriber.call("server.subscribe", {{"topics", {"job"}}});
  auto waiting = rig.tcp();
  waiting.send_raw(line_of(request(5, "slow.wait", {5})));
  auto local = rig.local();
  const auto start = std::chrono::steady_clock::now();
  EXPECT_TRUE(closed_by_server(silent));
  EXPECT_TRUE(closed_by_server(talked));
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(250));
  // Well past the timeout: the subscriber, the one awaiting its reply and the Unix one are still served.
  ASSERT_TRUE(rig.gate.wait_for_waiting(1));
  EXPECT_EQ(subscriber.call("echo", {2}), json({2}));
  rig.gate.open();
  EXPECT_EQ(next_reply(waiting).at("id"), 5);
  EXPECT_EQ(local.call("echo", {3}), json({3}));
  // Once answered, the one that waited has its idle_timeout_s again, and then it goes too.
  EXPECT_TRUE(closed_by_server(waiting));
}

// With tokens, a TCP connection that has not authenticated within auth_timeout_s is closed, even
// one that keeps talking (issue 13, D5).
TEST(RpcServerTest, AnUnauthenticatedTcpConnectionIsClosedAfterTheAuthTimeout) {
  ServerOptions options = test_options();
  options.tokens = {{"observer-token-0123456789", Role::observer}};
  options.auth_timeout_s = 0.3;
  Rig rig(options);
  auto anonymous = rig.raw_tcp();
  auto authed = rig.raw_tcp();
  EXPECT_EQ(authed.call("server.auth", {{"token", "observer-token-0123456789"}}).at("role"), "observer");
  authed.call("server.subscribe", {{"topics", {"job"}}});
  const auto start = std::chrono::steady_clock::now();
  bool closed = false;
  while (!closed && std::chrono::steady_clock::now() - start < std::chrono::seconds(20)) {
    try {
      anonymous.call("whoami");  // talking is not enough
    } catch (const RpcClientError&) {
      closed = true;
    }
  }
  EXPECT_TRUE(closed);
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(250));
  EXPECT_EQ(authed.call("echo", {1}), json({1}));
}

TEST(RpcServerTest, PendingLimitRefusesTheExcessAndFastCallsOvertake) {
  ServerOptions options = test_options();
  options.max_pending_requests = 2;
  Rig rig(options);
  auto client = rig.tcp();
  client.send_raw(line_of(request(1, "slow.wait", {1})) + line_of(request(2, "slow.wait", {2})) +
                  line_of(request(3, "slow.wait", {3})) + line_of(request(4, "echo", {4})));
  const json excess = next_reply(client);
  EXPECT_EQ(excess.at("id"), 3);
  EXPECT_EQ(excess.at("error").at("code"), rpc_code::too_many_pending);
  EXPECT_EQ(excess.at("error").at("data"), json({{"max_pending_requests", 2}}));
  EXPECT_EQ(next_reply(client).at("id"), 4);  // the quick one did not wait for the slow ones
  ASSERT_TRUE(rig.gate.wait_for_waiting(2));
  rig.gate.open();
  std::set<json> late = {next_reply(client).at("id"), next_reply(client).at("id")};
  EXPECT_EQ(late, (std::set<json>{1, 2}));
  EXPECT_EQ(client.call("slow.wait", {5}), json({5}));  // the places are free again
}

TEST(RpcServerTest, UnixSocketHasItsModeAndGivesOperator) {
  ServerOptions options = test_options();
  options.tokens = {{"op-token", Role::operator_}};
  Rig rig(options);
  struct stat st {};
  ASSERT_EQ(stat(rig.unix_path.c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 07777, 0660u);
  auto local = rig.local();
  EXPECT_EQ(local.call("admin.poke"), "poked");
}

TEST(RpcServerTest, TokensGateTcp) {
  ServerOptions options = test_options();
  options.tokens = {{"op-token", Role::operator_}, {"look-token", Role::observer}};
  Rig rig(options);
  auto client = rig.raw_tcp();
  EXPECT_EQ(client.call("whoami").at("role"), "none");
  const RpcError before = error_of([&] { client.call("echo", {1}); });
  EXPECT_EQ(before.code(), rpc_code::unauthorized);
  EXPECT_EQ(before.data(), json({{"needed", "observer"}}));
  EXPECT_EQ(error_of([&] { client.call("server.subscribe", {{"topics", {"job"}}}); }).code(), rpc_code::unauthorized);

  EXPECT_EQ(error_of([&] { client.call("server.auth", {{"token", "op-tokem"}}); }).code(), rpc_code::auth_failed);
  EXPECT_EQ(error_of([&] { client.call("server.auth", {{"token", ""}}); }).code(), rpc_code::auth_failed);
  const RpcError no_token = error_of([&] { client.call("server.auth", {{"secret", "op-token"}}); });
  EXPECT_EQ(no_token.code(), rpc_code::invalid_params);
  EXPECT_EQ(no_token.data(), json({{"path", "/token"}}));

  EXPECT_EQ(client.call("server.auth", {{"token", "look-token"}}), json({{"role", "observer"}}));
  EXPECT_EQ(client.call("echo", {1}), json({1}));
  const RpcError observer = error_of([&] { client.call("admin.poke"); });
  EXPECT_EQ(observer.code(), rpc_code::unauthorized);
  EXPECT_EQ(observer.data(), json({{"needed", "operator"}}));

  EXPECT_EQ(client.call("server.auth", {{"token", "op-token"}}), json({{"role", "operator"}}));
  EXPECT_EQ(client.call("admin.poke"), "poked");

  // Reloaded tokens: new connections follow them, granted roles stay. Without any, TCP is still
  // no role: never operator by being on this host.
  rig.server->set_tokens({});
  auto tokenless = rig.raw_tcp();
  EXPECT_EQ(tokenless.call("whoami").at("role"), "none");
  EXPECT_EQ(error_of([&] { tokenless.call("admin.poke"); }).code(), rpc_code::unauthorized);
  rig.server->set_tokens({{"new-token", Role::observer}});
  auto late = rig.raw_tcp();
  EXPECT_EQ(error_of([&] { late.call("server.auth", {{"token", "op-token"}}); }).code(), rpc_code::auth_failed);
  EXPECT_EQ(late.call("server.auth", {{"token", "new-token"}}), json({{"role", "observer"}}));
  EXPECT_EQ(client.call("admin.poke"), "poked");
}

TEST(RpcServerTest, NotificationsReachOnlySubscribers) {
  Rig rig;
  auto jobs = rig.tcp(), machine = rig.local(), nobody = rig.tcp();
  EXPECT_EQ(jobs.call("server.subscribe", {{"topics", {"job"}}}), json({{"topics", {"job"}}}));
  EXPECT_EQ(machine.call("server.subscribe", {{"topics", {"machine"}}}), json({{"topics", {"machine"}}}));
  const RpcError unknown = error_of([&] { nobody.call("server.subscribe", {{"topics", {"machine", "weather"}}}); });
  EXPECT_EQ(unknown.code(), rpc_code::invalid_params);
  EXPECT_EQ(unknown.data(), json({{"path", "/topics/1"}}));

  rig.server->notify("job", "job.state", {{"job", "j1"}, {"state", "probing"}});
  rig.server->notify("machine", "machine.state", {{"n", 1}});
  EXPECT_EQ(jobs.wait_notification(20), json({{"method", "job.state"}, {"params", {{"job", "j1"}, {"state", "probing"}}}}));
  // In order: had the machine subscriber got the job notification, it would come first.
  EXPECT_EQ(machine.wait_notification(20), json({{"method", "machine.state"}, {"params", {{"n", 1}}}}));

  // The unsubscribed connection got neither: its first notification is one sent after it subscribed.
  EXPECT_EQ(nobody.call("server.subscribe", {{"topics", {"machine"}}}), json({{"topics", {"machine"}}}));
  rig.server->notify("machine", "machine.state", {{"n", 2}});
  EXPECT_EQ(nobody.wait_notification(20), json({{"method", "machine.state"}, {"params", {{"n", 2}}}}));
  EXPECT_EQ(machine.wait_notification(20).value().at("params"), json({{"n", 2}}));

  // A notification that arrives while a call waits is kept for later.
  rig.server->notify("job", "job.progress", {{"done", 3}});
  EXPECT_EQ(jobs.call("echo", {1}), json({1}));
  rig.server->notify("job", "job.progress", {{"done", 4}});
  EXPECT_EQ(jobs.call("slow.echo", {2}), json({2}));
  EXPECT_EQ(jobs.wait_notification(20).value().at("params"), json({{"done", 3}}));
  EXPECT_EQ(jobs.wait_notification(20).value().at("params"), json({{"done", 4}}));
  EXPECT_FALSE(jobs.wait_notification(0.05).has_value());
}

TEST(RpcServerTest, ASubscriberThatDoesNotReadIsDropped) {
  ServerOptions options = test_options();
  options.max_unsent_bytes = 64 * 1024;
  Rig rig(options);
  auto sleeper = rig.tcp();
  sleeper.call("server.subscribe", {{"topics", {"job"}}});
  auto reader = rig.tcp();
  EXPECT_EQ(reader.call("echo", {0}), json({0}));  // both connections are in the count now
  ASSERT_EQ(rig.server->connection_count(), 2u);
  const json touch = {{"job", "j1"}, {"centre", std::string(1000, '7')}};
  // The kernel's socket buffers take a few MiB first; then unsent output grows past the bound.
  for (int i = 0; i < 100000 && rig.server->connection_count() == 2; ++i) rig.server->notify("job", "job.touch", touch);
  ASSERT_TRUE(eventually([&] { return rig.server->connection_count() == 1; }));
  EXPECT_EQ(reader.call("echo", {1}), json({1}));
  EXPECT_TRUE(closed_by_server(sleeper));
}

// A client that asks for replies and never reads them is dropped once they pass max_unsent_bytes,
// and all connections together cannot hold more than max_total_unsent_bytes (issue 13, D4).
TEST(RpcServerTest, AClientThatDoesNotReadItsRepliesIsDropped) {
  ServerOptions options = test_options();
  options.max_unsent_bytes = 48u << 20;
  options.max_total_unsent_bytes = 80u << 20;
  Rig rig(options);
  auto reader = rig.local();
  EXPECT_EQ(reader.call("echo", {0}), json({0}));
  // A reply counts as unsent until the last byte is out, which a client that reads nothing stops
  // long before 32 MiB: two fit the budget, the third does not.
  {
    std::vector<RpcClient> sleepers;
    for (int i = 0; i < 3; ++i) sleepers.push_back(rig.tcp());
    ASSERT_TRUE(eventually([&] { return rig.server->connection_count() == 4; }));
    for (int i = 0; i < 3; ++i) {
      sleepers[i].send_raw(line_of(request(i, "slow.big", {32u << 20})));
      if (i < 2) {
        ASSERT_TRUE(eventually([&] { return rig.server->unsent_bytes() >= (i + 1) * (32u << 20); }));
      }
    }
    EXPECT_TRUE(closed_by_server(sleepers[2])) << "the third reply is over the total";
    EXPECT_TRUE(eventually([&] { return rig.server->connection_count() == 3; }));
  }
  ASSERT_TRUE(eventually([&] { return rig.server->connection_count() == 1; }));
  // One connection alone: over its own limit with two replies of 32 MiB. (Reading to see it closed
  // would take the first reply and make room for the second: the count tells instead.)
  auto greedy = rig.tcp();
  ASSERT_TRUE(eventually([&] { return rig.server->connection_count() == 2; }));
  greedy.send_raw(line_of(request(10, "slow.big", {32u << 20})) + line_of(request(11, "slow.big", {32u << 20})));
  EXPECT_TRUE(eventually([&] { return rig.server->connection_count() == 1; }));
  EXPECT_EQ(reader.call("echo", {1}), json({1}));
}

TEST(RpcServerTest, ABatchOverTheLimitIsOneErrorAndTheConnectionStays) {
  ServerOptions options = test_options();
  options.max_batch_entries = 4;
  Rig rig(options);
  auto client = rig.tcp();
  const std::string batch = "[" + request(1, "echo", {1}).dump() + "," + request(2, "echo", {2}).dump() + ",1,2,3]";
  client.send_raw(batch + "\n");
  const json error = next_reply(client);
  EXPECT_EQ(error.at("error").at("code"), rpc_code::batch_too_large) << error;
  EXPECT_EQ(error.at("error").at("data"), json({{"max_batch_entries", 4}}));
  EXPECT_EQ(client.call("echo", {3}), json({3}));
}

// Previews run on their own workers and queue: flooding them leaves the blocking workers free, an
// observer's blocking calls never take the operator's workers, and a full queue is server_busy.
TEST(RpcServerTest, PlanningAndObserversCannotTakeTheOperatorsWorkers) {
  ServerOptions options = test_options();
  options.tokens = {{"observer-token-0123456789", Role::observer}};
  options.workers = {.operator_threads = 1, .observer_threads = 1, .planning_threads = 1, .max_queued_planning = 1};
  Rig rig(options);
  auto observer = rig.tcp();
  observer.call("server.auth", {{"token", "observer-token-0123456789"}});
  observer.send_raw(line_of(request(1, "plan.wait", {1})) + line_of(request(2, "plan.wait", {2})) +
                    line_of(request(3, "plan.wait", {3})) + line_of(request(4, "slow.wait", {4})));
  const json busy = next_reply(observer);
  EXPECT_EQ(busy.at("id"), 3);
  EXPECT_EQ(busy.at("error").at("code"), rpc_code::server_busy) << busy;
  ASSERT_TRUE(rig.gate.wait_for_waiting(2));  // one preview and the observer's slow call hold their workers
  auto operator_client = rig.local();
  EXPECT_EQ(operator_client.call("slow.echo", {5}), json({5}));
  rig.gate.open();
  std::set<json> answered;
  for (int i = 0; i < 3; ++i) answered.insert(next_reply(observer).at("id"));
  EXPECT_EQ(answered, (std::set<json>{1, 2, 4}));
}

// Requests waiting for the workers are bounded in bytes for all connections together: 64 pending
// lines of 4 MiB each would otherwise be gigabytes of parsed JSON.
TEST(RpcServerTest, RequestsWaitingForTheWorkersAreBoundedInBytes) {
  ServerOptions options = test_options();
  options.workers.operator_threads = 1;
  options.workers.max_waiting_bytes = 3u << 20;
  Rig rig(options);
  auto client = rig.local();
  const std::string pad(1u << 20, 'p');
  std::string lines;
  for (int i = 0; i < 4; ++i) lines += line_of(request(i, "slow.wait", {pad}));
  client.send_raw(lines);
  const json busy = next_reply(client);
  EXPECT_EQ(busy.at("id"), 2) << busy.dump().substr(0, 200);  // the third brings over 3 MiB
  EXPECT_EQ(busy.at("error").at("code"), rpc_code::server_busy);
  EXPECT_EQ(next_reply(client).at("id"), 3);
  rig.gate.open();
  std::set<json> answered = {next_reply(client).at("id"), next_reply(client).at("id")};
  EXPECT_EQ(answered, (std::set<json>{0, 1}));
  // Once they are answered, their bytes are free again.
  EXPECT_EQ(client.call("slow.echo", {pad}).at(0).get<std::string>().size(), pad.size());
}

// A long handler sees its connection close when the server stops (cmmd's SIGTERM), so a preview
// ends at its next step and the stop does not wait for it.
TEST(RpcServerTest, AHandlerSeesItsConnectionCloseWhenTheServerStops) {
  Rig rig;
  auto client = rig.tcp();
  client.send_raw(line_of(request(1, "plan.until_closed")));
  ASSERT_TRUE(eventually([&] { return rig.running.load(); }));
  const auto start = std::chrono::steady_clock::now();
  rig.stop();  // joins the workers: returns once the handler has
  EXPECT_TRUE(rig.saw_closed.load());
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

// Token guessing: a connection is closed after its third wrong token, and once an address's wrong
// tokens are over its allowance each is answered as throttled and closes its connection (issue 13:
// 34,000 guesses in 0.33 s). The right token is compared first and always works, from that
// address too (issue 33: a flood of wrong tokens made the operator's fail).
TEST(RpcServerTest, TokenGuessingIsThrottledPerAddressAndNeverRefusesTheRightToken) {
  ServerOptions options = test_options();
  options.tokens = {{"operator-token-0123456789", Role::operator_}};
  Rig rig(options);
  auto guesser = rig.raw_tcp();
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(error_of([&] { guesser.call("server.auth", {{"token", "guess-" + std::to_string(i)}}); }).code(),
              rpc_code::auth_failed);
  EXPECT_TRUE(closed_by_server(guesser));

  int throttled = 0;
  for (int i = 0; i < 30 && throttled == 0; ++i) {
    auto next = rig.raw_tcp();
    const RpcError e = error_of([&] { next.call("server.auth", {{"token", "guess"}}); });
    EXPECT_EQ(e.code(), rpc_code::auth_failed);
    if (e.data().contains("retry_after_s")) {
      ++throttled;
      EXPECT_TRUE(closed_by_server(next)) << "a throttled guess keeps its connection";
    }
  }
  EXPECT_EQ(throttled, 1) << "the guessing address was never throttled";
  auto right = rig.raw_tcp();
  EXPECT_EQ(right.call("server.auth", {{"token", "operator-token-0123456789"}}).at("role"), "operator")
      << "the right token was refused while its address is throttled";
}

TEST(RpcServerTest, HundredClientsAtOnce) {
  ServerOptions options = test_options();
  options.max_unix_connections = 100;
  Rig rig(options);
  constexpr int kClients = 100, kCalls = 40;
  std::atomic<int> ok{0};
  std::mutex failure_mutex;
  std::string failure;
  {
    std::vector<std::jthread> threads;
    for (int c = 0; c < kClients; ++c)
      threads.emplace_back([&, c] {
        try {
          auto client = c % 2 ? rig.tcp() : rig.local();
          for (int i = 0; i < kCalls; ++i) {
            const json params = {{"client", c}, {"call", i}};
            if (client.call(i % 5 == 0 ? "slow.echo" : "echo", params) == params) ++ok;
          }
        } catch (const std::exception& e) {
          std::lock_guard lock(failure_mutex);
          failure = e.what();
        }
      });
  }
  EXPECT_EQ(failure, "");
  EXPECT_EQ(ok, kClients * kCalls);
  EXPECT_TRUE(eventually([&] { return rig.server->connection_count() == 0; }));
}

TEST(RpcServerTest, StopClosesConnectedClientsAndRemovesTheSocket) {
  Rig rig;
  auto subscriber = rig.tcp(), local = rig.local();
  subscriber.call("server.subscribe", {{"topics", {"job"}}});
  local.call("echo");
  ASSERT_TRUE(fs::exists(rig.unix_path));
  rig.stop();
  EXPECT_EQ(rig.server->connection_count(), 0u);
  EXPECT_TRUE(closed_by_server(subscriber));
  EXPECT_TRUE(closed_by_server(local));
  EXPECT_FALSE(fs::exists(rig.unix_path));
  rig.server->notify("job", "job.state", {});  // harmless after stop
  try {
    RpcClient::connect(rig.tcp_endpoint(), 10);
    ADD_FAILURE() << "connected after stop";
  } catch (const RpcClientError& e) {
    EXPECT_THAT(e.what(), HasSubstr("Connection refused"));
  }
}

TEST(RpcServerTest, NonLoopbackBindWithoutTokensIsRefused) {
  asio::io_context io;
  RpcDispatcher dispatcher;
  ServerOptions options = test_options();
  options.tcp_bind = "0.0.0.0";
  RpcServer server(io, dispatcher, options);
  try {
    server.start();
    ADD_FAILURE() << "started";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("tcp://0.0.0.0:0"));
    EXPECT_THAT(e.what(), HasSubstr("not a loopback address"));
  }
}

TEST(RpcServerTest, StartNamesWhatIsInTheWay) {
  Rig rig;
  const auto start_error = [](ServerOptions options) -> std::string {
    asio::io_context io;
    RpcDispatcher dispatcher;
    RpcServer server(io, dispatcher, std::move(options));
    try {
      server.start();
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "started";
  };
  ServerOptions same_port = test_options();
  same_port.tcp_port = rig.server->tcp_port();
  EXPECT_THAT(start_error(same_port), HasSubstr("Address already in use"));

  ServerOptions same_socket = test_options();
  same_socket.unix_path = rig.unix_path;
  same_socket.tcp_enabled = false;
  EXPECT_THAT(start_error(same_socket), HasSubstr("another process is listening on it"));
  EXPECT_TRUE(fs::exists(rig.unix_path));  // and it is left alone

  ServerOptions a_file = test_options();
  a_file.tcp_enabled = false;
  std::ofstream(a_file.unix_path) << "not a socket";
  EXPECT_THAT(start_error(a_file), HasSubstr("exists and is not a socket"));
  fs::remove(a_file.unix_path);

  ServerOptions no_folder = test_options();
  no_folder.tcp_enabled = false;
  no_folder.unix_path = ::testing::TempDir() + "no-such-folder-" + std::to_string(getpid()) + "/cmmd.sock";
  EXPECT_THAT(start_error(no_folder), HasSubstr("cannot listen on unix:" + no_folder.unix_path + ": No such file or directory"));
}

TEST(RpcServerTest, AStaleSocketIsReplaced) {
  ServerOptions options = test_options();
  {
    asio::io_context io;
    asio::local::stream_protocol::acceptor left_behind(io, asio::local::stream_protocol::endpoint(options.unix_path));
  }  // closed, the file stays: what a killed cmmd leaves
  ASSERT_TRUE(fs::exists(options.unix_path));
  Rig rig(options);
  EXPECT_EQ(rig.local().call("echo", {1}), json({1}));
}

TEST(RpcClientTest, TransportProblemsNameTheEndpoint) {
  const std::string missing = ::testing::TempDir() + "cmmd-rpc-missing.sock";
  try {
    RpcClient::connect("unix:" + missing, 5);
    ADD_FAILURE();
  } catch (const RpcClientError& e) {
    EXPECT_EQ(std::string(e.what()), "cannot connect to unix:" + missing + ": No such file or directory — is cmmd running?");
  }
  EXPECT_THROW(RpcClient::connect("http://localhost:7620", 5), RpcClientError);

  Rig rig;
  auto client = rig.tcp();
  try {
    client.call("slow.wait", {1}, 0.2);
    ADD_FAILURE();
  } catch (const RpcClientError& e) {
    EXPECT_EQ(std::string(e.what()), rig.tcp_endpoint() + ": no reply to slow.wait within 0.2 s");
  }
  rig.gate.open();
  EXPECT_EQ(client.call("echo", {2}), json({2}));  // the late reply to the first call is skipped
  rig.stop();
  try {
    client.call("echo");
    ADD_FAILURE();
  } catch (const RpcClientError& e) {
    EXPECT_EQ(std::string(e.what()), rig.tcp_endpoint() + ": connection closed by cmmd");
  }
}

}  // namespace
}  // namespace cmm::daemon
