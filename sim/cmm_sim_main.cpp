// cmm-sim: one simulated CMM served for hardware-in-the-loop runs: Modbus TCP on loopback and, on
// request, Grbl 1.1 on a serial pty or device and I++ DME on a TCP port. Prints one JSON ready line
// on stdout, then serves until SIGTERM.
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>

#include <CLI/CLI.hpp>
#include <unistd.h>

#include "hal/description/json_fields.hpp"
#include "hal/modbus_map.hpp"
#include "hal/protocol_log.hpp"
#include "sim/grbl_server.hpp"
#include "sim/ippdme_server.hpp"
#include "sim/modbus_server.hpp"
#include "sim/sim_config.hpp"
#include "sim/simulated_machine.hpp"

namespace {
volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cmm-sim: a simulated CMM served over Modbus TCP (and RTU, Grbl 1.1 on a serial line, I++ DME on TCP) for hardware-in-the-loop tests"};
  std::string config_file, host = "127.0.0.1";
  int port = 0;
  double time_scale = -1;
  bool print_map = false, grbl_pty = false;
  std::string rtu_device, grbl_device, ippdme_log_file, ippdme_pending = "answer";
  int rtu_baud = 115200, ippdme_port = -1;
  app.add_option("--config", config_file, "simulator config JSON (docs/hal.md); default: the built-in machine")
      ->check(CLI::ExistingFile);
  app.add_option("--host", host, "address to listen on (loopback unless you mean otherwise)");
  app.add_option("--port", port, "Modbus TCP port; 0 picks a free one (see the ready line)")->check(CLI::Range(0, 65535));
  app.add_option("--time-scale", time_scale, "run motion in wall time / this; 0 = no wall time (overrides the config)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--modbus-rtu", rtu_device, "also serve Modbus RTU (unit 1, 8N1) on this serial device, e.g. a socat pty");
  app.add_option("--modbus-rtu-baud", rtu_baud, "baud rate of --modbus-rtu")->check(CLI::PositiveNumber);
  app.add_flag("--grbl-pty", grbl_pty, "also serve Grbl 1.1 on a new pty (its path: grbl_pty in the ready line)");
  app.add_option("--grbl-device", grbl_device, "also serve Grbl 1.1 on this serial device (a socat pty, a UART)");
  auto* ippdme_option =
      app.add_option("--ippdme", ippdme_port, "also serve I++ DME on this TCP port of --host; 0 picks a free one (ippdme in the ready line)")
          ->check(CLI::Range(0, 65535));
  app.add_option("--ippdme-log", ippdme_log_file, "append every I++ DME line received and sent to this file")
      ->needs(ippdme_option);
  app.add_option("--ippdme-pending-on-error", ippdme_pending,
                 "what becomes of queued I++ transactions after a severity >= 2 error: answer (0006 and %, as the "
                 "specification) or drop (no answer, as NIST's test-suite server)")
      ->check(CLI::IsMember({"answer", "drop"}))
      ->needs(ippdme_option);
  app.add_flag("--print-modbus-map", print_map, "print the register map as Markdown and exit");
  CLI11_PARSE(app, argc, argv);
  if (print_map) {
    std::cout << cmm::hal::modbus::markdown_table();
    return 0;
  }

  try {
    nlohmann::json block = nlohmann::json::object();
    std::string base_dir = ".";
    if (!config_file.empty()) {
      block = cmm::description::read_json_file(config_file, "the simulator's config");
      base_dir = std::filesystem::absolute(config_file).parent_path().string();
    }
    if (time_scale >= 0) block["time_scale"] = time_scale;
    const cmm::sim::SimConfig config = cmm::sim::sim_config_from_json(block, base_dir);
    cmm::sim::SimulatedMachine machine(config);
    cmm::sim::ModbusServer modbus(machine, config.faults, cmm::sim::ModbusTcpEndpoint{host, port});
    // Every server is built before any thread starts, so a bad device fails here with a message.
    std::unique_ptr<cmm::sim::ModbusServer> rtu;
    if (!rtu_device.empty())
      rtu = std::make_unique<cmm::sim::ModbusServer>(machine, config.faults, cmm::sim::ModbusRtuEndpoint{rtu_device, rtu_baud});
    std::unique_ptr<cmm::sim::GrblServer> grbl;
    if (grbl_pty || !grbl_device.empty()) grbl = std::make_unique<cmm::sim::GrblServer>(machine, config.faults, grbl_device);
    std::unique_ptr<cmm::hal::ProtocolLog> ippdme_log;
    if (!ippdme_log_file.empty()) ippdme_log = std::make_unique<cmm::hal::ProtocolLog>(ippdme_log_file);
    std::unique_ptr<cmm::sim::IppDmeServer> ippdme;
    if (ippdme_port >= 0)
      ippdme = std::make_unique<cmm::sim::IppDmeServer>(
          machine, config.faults, cmm::sim::IppDmeEndpoint{host, ippdme_port}, ippdme_log.get(),
          cmm::sim::IppDmeOptions{ippdme_pending == "drop" ? cmm::sim::PendingOnError::drop : cmm::sim::PendingOnError::answer});
    // A side that fails while serving says so and ends cmm-sim, rather than terminating it.
    auto serving = [](auto& server, const char* side) {
      return std::thread([&server, side] {
        try {
          server->serve();
        } catch (const std::exception& e) {
          std::cerr << "cmm-sim: " << side << ": " << e.what() << "\n";
          g_stop = 1;
        }
      });
    };
    std::thread rtu_loop, grbl_thread, ippdme_thread;
    if (rtu) rtu_loop = serving(rtu, "Modbus RTU");
    if (grbl) grbl_thread = serving(grbl, "Grbl");
    if (ippdme) ippdme_thread = serving(ippdme, "I++ DME");

    std::signal(SIGTERM, on_signal);
    std::signal(SIGINT, on_signal);
    std::signal(SIGPIPE, SIG_IGN);  // a client that hangs up mid-reply is the loop's business
    std::thread watcher([&] {
      while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(20));
      modbus.shutdown();
      if (rtu) rtu->shutdown();
      if (grbl) grbl->shutdown();
      if (ippdme) ippdme->shutdown();
    });
    nlohmann::json ready = {{"ready", true}, {"modbus_tcp", modbus.port()}, {"host", host}, {"pid", getpid()},
                            {"time_scale", config.time_scale}, {"seed", config.seed}};
    if (rtu) ready["modbus_rtu"] = rtu_device;
    if (grbl) ready["grbl_pty"] = grbl->slave_path();
    if (ippdme) ready["ippdme"] = ippdme->port();
    std::cout << ready.dump() << std::endl;
    int status = 0;
    try {
      modbus.serve();
    } catch (const std::exception& e) {
      std::cerr << "cmm-sim: Modbus TCP: " << e.what() << "\n";
      status = 1;
    }
    g_stop = 1;
    watcher.join();
    if (rtu_loop.joinable()) rtu_loop.join();
    if (grbl_thread.joinable()) grbl_thread.join();
    if (ippdme_thread.joinable()) ippdme_thread.join();
    return status;
  } catch (const cmm::description::FieldError& e) {
    std::cerr << "cmm-sim: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "cmm-sim: " << e.what() << "\n";
    return 1;
  }
}
