// JSON-RPC round trips through cmmd's RpcServer and RpcClient against a bare Asio line echo on the
// same loopback TCP, in one run: what the protocol layer (JSON, dispatch, framing, the blocking
// client) costs over the transport, with 1 client and with 50 at once.
#include <benchmark/benchmark.h>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/post.hpp>
#include <asio/read_until.hpp>
#include <asio/write.hpp>

#include "daemon/client/json_rpc.hpp"
#include "daemon/client/rpc_client.hpp"
#include "daemon/rpc_server.hpp"

namespace {

using namespace cmm::daemon;
using nlohmann::json;
using Clock = std::chrono::steady_clock;
using asio::ip::tcp;

// The echoed params: a sequence number and 64 bytes of text, about what job.get asks.
json echo_params(std::int64_t seq) { return {{"seq", seq}, {"text", std::string(64, 'x')}}; }

const std::string kBenchToken = "json-rpc-bench-observer-token";

// cmmd's server on its own io thread, as cmmd runs it, with one fast method.
struct RpcRig {
  asio::io_context io;
  RpcDispatcher dispatcher;
  std::optional<RpcServer> server;
  std::thread thread;
  RpcRig() {
    spdlog::set_level(spdlog::level::warn);  // no line per connection
    dispatcher.add("echo", {Role::observer, Work::quick, [](const json& p, RpcContext&) { return p; }});
    ServerOptions options;
    options.tcp_port = 0;
    options.tokens = {{kBenchToken, Role::observer}};  // TCP is a role only by a token
    server.emplace(io, dispatcher, options);
    server->start();
    thread = std::thread([this] { io.run(); });
  }
  ~RpcRig() {
    asio::post(io, [this] { server->stop(); });
    thread.join();
  }
};
RpcRig& rpc_rig() {
  static RpcRig rig;
  return rig;
}

// The floor: an Asio server on one io thread that writes each line back as it came.
struct BareEchoRig {
  struct Connection : std::enable_shared_from_this<Connection> {
    explicit Connection(tcp::socket s) : socket(std::move(s)) {}
    void read() {
      asio::async_read_until(socket, asio::dynamic_buffer(buffer), '\n',
                             [self = shared_from_this()](const asio::error_code& ec, std::size_t n) {
                               if (!ec) self->write(n);
                             });
    }
    void write(std::size_t n) {
      asio::async_write(socket, asio::buffer(buffer.data(), n),
                        [self = shared_from_this(), n](const asio::error_code& ec, std::size_t) {
                          if (ec) return;
                          self->buffer.erase(0, n);
                          self->read();
                        });
    }
    tcp::socket socket;
    std::string buffer;
  };

  asio::io_context io;
  tcp::acceptor acceptor{io, tcp::endpoint(asio::ip::address_v4::loopback(), 0)};
  std::thread thread;
  BareEchoRig() {
    accept();
    thread = std::thread([this] { io.run(); });
  }
  ~BareEchoRig() {
    io.stop();
    thread.join();
  }
  void accept() {
    acceptor.async_accept([this](const asio::error_code& ec, tcp::socket socket) {
      if (ec) return;
      socket.set_option(tcp::no_delay(true));
      std::make_shared<Connection>(std::move(socket))->read();
      accept();
    });
  }
};
BareEchoRig& bare_rig() {
  static BareEchoRig rig;
  return rig;
}

RpcClient authenticated_client() {
  RpcClient client = RpcClient::connect("tcp://127.0.0.1:" + std::to_string(rpc_rig().server->tcp_port()), 10);
  client.call("server.auth", {{"token", kBenchToken}});
  return client;
}

struct RpcEchoClient {
  RpcClient client = authenticated_client();
  std::size_t request_bytes = to_wire(json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", "echo"}, {"params", echo_params(1)}}).size() + 1;
  bool round_trip(std::int64_t seq) { return client.call("echo", echo_params(seq)).at("seq") == seq; }
};

// A blocking Asio client sending the same bytes cmmd's client would, with no JSON either side.
struct BareEchoClient {
  asio::io_context io;
  tcp::socket socket{io};
  std::string line = to_wire(json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", "echo"}, {"params", echo_params(1)}}) + "\n";
  std::string inbox;
  std::size_t request_bytes = line.size();
  BareEchoClient() {
    socket.connect(bare_rig().acceptor.local_endpoint());
    socket.set_option(tcp::no_delay(true));
  }
  bool round_trip(std::int64_t) {
    asio::write(socket, asio::buffer(line));
    const std::size_t n = asio::read_until(socket, asio::dynamic_buffer(inbox), '\n');
    inbox.erase(0, n);
    return n == line.size();
  }
};

double percentile(std::vector<double>& sorted_us, double q) {
  if (sorted_us.empty()) return 0;
  return sorted_us[std::min(sorted_us.size() - 1, static_cast<std::size_t>(q * static_cast<double>(sorted_us.size())))];
}

// Each benchmark thread is one client on its own connection. Percentiles are per client, then
// averaged over the clients; requests/s is summed over them.
template <typename Client>
void round_trips(benchmark::State& state) {
  std::optional<Client> client;
  try {
    client.emplace();
  } catch (const std::exception& e) {
    return state.SkipWithError(e.what());
  }
  std::vector<double> us;
  std::int64_t seq = 0;
  const auto start = Clock::now();
  for (auto _ : state) {
    const auto before = Clock::now();
    if (!client->round_trip(++seq)) return state.SkipWithError("wrong echo");
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - before).count());
  }
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  std::sort(us.begin(), us.end());
  state.counters["p50_us"] = benchmark::Counter(percentile(us, 0.50), benchmark::Counter::kAvgThreads);
  state.counters["p99_us"] = benchmark::Counter(percentile(us, 0.99), benchmark::Counter::kAvgThreads);
  state.counters["req_per_s"] = benchmark::Counter(static_cast<double>(us.size()) / elapsed_s);
  state.counters["request_bytes"] = benchmark::Counter(static_cast<double>(client->request_bytes), benchmark::Counter::kAvgThreads);
  state.SetItemsProcessed(state.iterations());
}

void bm_rpc_echo(benchmark::State& state) { round_trips<RpcEchoClient>(state); }
void bm_bare_echo(benchmark::State& state) { round_trips<BareEchoClient>(state); }

}  // namespace

BENCHMARK(bm_rpc_echo)->Threads(1)->Threads(50)->UseRealTime()->MinTime(2);
BENCHMARK(bm_bare_echo)->Threads(1)->Threads(50)->UseRealTime()->MinTime(2);
BENCHMARK_MAIN();
