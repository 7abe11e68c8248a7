// HAL round trips per second on each path against its bare transport, in one run: the driver's own
// overhead (encoding, the sequence echo, lifecycle checks) should be small beside the transport's.
// The servers are cmm-sim's own, run in this process: Modbus and I++ DME on loopback TCP, Grbl on a
// pty.
#include <benchmark/benchmark.h>

#include <modbus/modbus.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <pty.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "hal/grbl_cmm.hpp"
#include "hal/ippdme_cmm.hpp"
#include "hal/modbus_cmm.hpp"
#include "hal/modbus_map.hpp"
#include "sim/grbl_server.hpp"
#include "sim/ippdme_server.hpp"
#include "sim/modbus_server.hpp"
#include "sim/simulated_cmm.hpp"

namespace {

using namespace cmm;

// One simulated machine served over Modbus TCP for the whole run.
struct ModbusRig {
  sim::SimConfig config = sim::sim_config_from_json({{"part", {{"analytic", "cube"}, {"edge_length_mm", 4}}}});
  sim::SimulatedMachine machine{config};
  sim::ModbusServer server{machine, config.faults, sim::ModbusTcpEndpoint{}};
  std::thread loop{[this] { server.serve(); }};
  ~ModbusRig() {
    server.shutdown();
    loop.join();
  }
};
ModbusRig& rig() {
  static ModbusRig r;
  return r;
}

std::unique_ptr<hal::ModbusCmm> modbus_driver() {
  auto cmm = std::make_unique<hal::ModbusCmm>();
  cmm->configure({{"driver", "modbus"}, {"port", rig().server.port()}, {"poll_interval_s", 0}, {"heartbeat_s", 0}});
  cmm->connect();
  cmm->enable();
  return cmm;
}

// The transport alone: libmodbus reading the 25-register status block from the same server.
void bm_modbus_bare_read(benchmark::State& state) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", rig().server.port());
  modbus_connect(ctx);
  std::uint16_t regs[hal::modbus::kStatusCount];
  for (auto _ : state)
    if (modbus_read_registers(ctx, hal::modbus::kStatusFirst, hal::modbus::kStatusCount, regs) < 0) state.SkipWithError("read");
  state.SetItemsProcessed(state.iterations());
  modbus_close(ctx);
  modbus_free(ctx);
}

// hal::ModbusCmm::status(): the same read, decoded into a MachineStatus.
void bm_modbus_status(benchmark::State& state) {
  auto cmm = modbus_driver();
  for (auto _ : state) benchmark::DoNotOptimize(cmm->status());
  state.SetItemsProcessed(state.iterations());
}

// A command's bare transport: one block write and one status read (the least a command can cost).
void bm_modbus_bare_command(benchmark::State& state) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", rig().server.port());
  modbus_connect(ctx);
  std::uint16_t block[hal::modbus::kCommandCount] = {}, regs[hal::modbus::kStatusCount];
  for (auto _ : state) {
    modbus_write_registers(ctx, hal::modbus::kCommandFirst, hal::modbus::kCommandCount, block);  // seq 0: ignored
    modbus_read_registers(ctx, hal::modbus::kStatusFirst, hal::modbus::kStatusCount, regs);
  }
  state.SetItemsProcessed(state.iterations());
  modbus_close(ctx);
  modbus_free(ctx);
}

// hal::ModbusCmm::move() to where the machine already is: a whole command with its echo, no motion.
void bm_modbus_move(benchmark::State& state) {
  auto cmm = modbus_driver();
  cmm->home();
  const hal::Move here{cmm->status().position, 0};
  for (auto _ : state) cmm->move(here);
  state.SetItemsProcessed(state.iterations());
}

// A serial line's transport alone: a pty pair whose far end answers each '?' with a status-report
// sized line at once, the least a Grbl status round trip can cost.
void bm_pty_bare_echo(benchmark::State& state) {
  int master = -1, slave = -1;
  if (openpty(&master, &slave, nullptr, nullptr, nullptr) != 0) return state.SkipWithError("openpty");
  termios raw{};
  tcgetattr(slave, &raw);
  cfmakeraw(&raw);
  tcsetattr(slave, TCSANOW, &raw);
  std::atomic<bool> done{false};
  std::thread far_end([&] {
    const std::string report = "<Idle|MPos:278.000000,353.000000,60.000000|FS:0,0>\r\n";
    char c;
    while (!done && ::read(slave, &c, 1) == 1)
      if (c == '?' && ::write(slave, report.data(), report.size()) < 0) return;
  });
  char line[256];
  for (auto _ : state) {
    if (::write(master, "?", 1) != 1) return state.SkipWithError("write");
    std::size_t got = 0;
    while (got == 0 || line[got - 1] != '\n') {
      const ssize_t n = ::read(master, line + got, sizeof line - got);
      if (n <= 0) return state.SkipWithError("read");
      got += static_cast<std::size_t>(n);
    }
  }
  state.SetItemsProcessed(state.iterations());
  done = true;
  if (::write(master, "x", 1) < 0) {}
  far_end.join();
  close(master);
  close(slave);
}

// cmm-sim's Grbl side on a pty in this process, and hal::GrblCmm on the pty's other end.
struct GrblRig {
  sim::SimConfig config = sim::sim_config_from_json({{"part", {{"analytic", "cube"}, {"edge_length_mm", 4}}}});
  sim::SimulatedMachine machine{config};
  sim::GrblServer server{machine, config.faults};
  std::thread loop{[this] { server.serve(); }};
  hal::GrblCmm cmm;
  GrblRig() {
    cmm.configure({{"driver", "grbl"}, {"device", server.slave_path()}, {"reset_on_open", false},
                   {"poll_interval_s", 0.0001}, {"machine", description::to_json(config.machine)}});
    cmm.connect();
    cmm.enable();
  }
  ~GrblRig() {
    cmm.disconnect();
    server.shutdown();
    loop.join();
  }
};

// The same server's pty read bare: write `?`, read the report line, parse nothing.
void bm_grbl_bare_status(benchmark::State& state) {
  sim::SimConfig config = sim::sim_config_from_json({{"part", {{"analytic", "cube"}, {"edge_length_mm", 4}}}});
  sim::SimulatedMachine machine{config};
  sim::GrblServer server{machine, config.faults};
  std::thread loop{[&] { server.serve(); }};
  const int fd = ::open(server.slave_path().c_str(), O_RDWR | O_NOCTTY);
  termios raw{};
  tcgetattr(fd, &raw);
  cfmakeraw(&raw);
  tcsetattr(fd, TCSANOW, &raw);
  // Lines are split out of what each read returns: the banner and the report may come in one read.
  std::string pending;
  char chunk[512];
  auto report = [&] {
    if (::write(fd, "?", 1) != 1) return false;
    for (;;) {
      for (std::size_t end; (end = pending.find('\n')) != std::string::npos;) {
        const bool is_report = pending[0] == '<';
        pending.erase(0, end + 1);
        if (is_report) return true;  // anything else (the banner, a message) is not the report
      }
      const ssize_t n = ::read(fd, chunk, sizeof chunk);
      if (n <= 0) return false;
      pending.append(chunk, static_cast<std::size_t>(n));
    }
  };
  for (auto _ : state)
    if (!report()) return state.SkipWithError("no status report");
  state.SetItemsProcessed(state.iterations());
  close(fd);
  server.shutdown();
  loop.join();
}

// hal::GrblCmm::status(): a `?` and its status report, parsed.
void bm_grbl_status(benchmark::State& state) {
  GrblRig rig;
  for (auto _ : state) benchmark::DoNotOptimize(rig.cmm.status());
  state.SetItemsProcessed(state.iterations());
}

// hal::GrblCmm::move() there and back by 1 µm: a G38.3 line, its ok, and the status polls around it.
void bm_grbl_move(benchmark::State& state) {
  GrblRig rig;
  rig.cmm.home();
  const hal::Vec3 a = rig.cmm.status().position, b = a - hal::Vec3(0, 0, 0.001);
  bool there = false;
  for (auto _ : state) rig.cmm.move({(there = !there) ? b : a, 0});
  state.SetItemsProcessed(state.iterations());
}

// cmm-sim's I++ DME side on loopback TCP in this process, one session at a time.
struct IppDmeRig {
  sim::SimConfig config = sim::sim_config_from_json({{"part", {{"analytic", "cube"}, {"edge_length_mm", 4}}}});
  sim::SimulatedMachine machine{config};
  sim::IppDmeServer server{machine, config.faults, sim::IppDmeEndpoint{}};
  std::thread loop{[this] { server.serve(); }};
  ~IppDmeRig() {
    server.shutdown();
    loop.join();
  }
};

// The line the driver's status() sends: the axes and cmm-sim's Clock() (the driver asks for it once
// it knows the server has it), so that both sides carry the same bytes.
constexpr const char* kGetLine = "Get(X(), Y(), Z(), Clock())";

// A bare I++ client: a blocking socket, a session, then `Get(...)` and its `&`, `#`, `%` lines read
// back, no parsing: the least an I++ position round trip can cost on this server.
void bm_ippdme_bare_get(benchmark::State& state) {
  IppDmeRig rig;
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(rig.server.port()));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return state.SkipWithError("connect");
  std::string pending;
  char buffer[4096];
  // Sends one command and reads up to its `%` (or an error).
  auto transact = [&](int tag, const std::string& command) {
    char head[8];
    std::snprintf(head, sizeof head, "%05d ", tag % 100000);
    const std::string line = head + command + "\r\n";
    if (::send(fd, line.data(), line.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(line.size())) return false;
    const std::string done = std::string(head) + "%", failed = std::string(head) + "!";
    for (;;) {
      const auto end = pending.find('\n');
      if (end != std::string::npos) {
        const std::string got = pending.substr(0, end);
        pending.erase(0, end + 1);
        if (got.rfind(done, 0) == 0) return true;
        if (got.rfind(failed, 0) == 0) return false;
        continue;
      }
      const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
      if (n <= 0) return false;
      pending.append(buffer, static_cast<std::size_t>(n));
    }
  };
  if (!transact(1, "StartSession()")) return state.SkipWithError("StartSession");
  int tag = 1;
  for (auto _ : state)
    if (!transact(++tag % 99999 + 1, kGetLine)) return state.SkipWithError("Get");
  state.SetItemsProcessed(state.iterations());
  transact(++tag % 99999 + 1, "EndSession()");
  ::close(fd);
}

// hal::IppDmeCmm::status() when idle: the same Get through the driver (tag, transaction, parse by name).
void bm_ippdme_status(benchmark::State& state) {
  IppDmeRig rig;
  hal::IppDmeCmm cmm;
  cmm.configure({{"driver", "ippdme"}, {"port", rig.server.port()}, {"machine", description::to_json(rig.config.machine)}});
  cmm.connect();
  for (auto _ : state) benchmark::DoNotOptimize(cmm.status());
  state.SetItemsProcessed(state.iterations());
  cmm.disconnect();
}

// The in-process simulator, for scale: no transport at all.
void bm_in_process_status(benchmark::State& state) {
  sim::SimulatedCmm cmm;
  cmm.configure({{"part", {{"analytic", "cube"}, {"edge_length_mm", 4}}}});
  cmm.connect();
  for (auto _ : state) benchmark::DoNotOptimize(cmm.status());
  state.SetItemsProcessed(state.iterations());
}

BENCHMARK(bm_modbus_bare_read)->UseRealTime()->MinTime(1.0);
BENCHMARK(bm_modbus_status)->UseRealTime()->MinTime(1.0);
BENCHMARK(bm_modbus_bare_command)->UseRealTime()->MinTime(1.0);
BENCHMARK(bm_modbus_move)->UseRealTime()->MinTime(1.0);
BENCHMARK(bm_pty_bare_echo)->UseRealTime()->MinTime(1.0);
BENCHMARK(bm_grbl_bare_status)->UseRealTime()->MinTime(1.0);
BENCHMARK(bm_grbl_status)->UseRealTime()->MinTime(1.0);
BENCHMARK(bm_grbl_move)->UseRealTime()->MinTime(1.0);
BENCHMARK(bm_ippdme_bare_get)->UseRealTime()->MinTime(1.0);
BENCHMARK(bm_ippdme_status)->UseRealTime()->MinTime(1.0);
BENCHMARK(bm_in_process_status)->UseRealTime()->MinTime(0.5);

}  // namespace

BENCHMARK_MAIN();
