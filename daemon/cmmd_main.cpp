// cmmd: the CMM control daemon. Reads cmmd.json, brings up the machine driver, serves JSON-RPC over
// TCP and a Unix socket, runs jobs one at a time, and tells systemd how it is doing.
#include <CLI/CLI.hpp>
#include <asio.hpp>
#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <mutex>
#include <thread>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "daemon/daemon_config.hpp"
#include "daemon/dashboard_access.hpp"
#include "daemon/driver_factory.hpp"
#include "daemon/job_manager.hpp"
#include "daemon/job_store.hpp"
#include "daemon/machine_link.hpp"
#include "daemon/metrics.hpp"
#include "daemon/mqtt_station.hpp"
#include "daemon/model_store.hpp"
#include "daemon/rpc_server.hpp"
#include "daemon/service_methods.hpp"
#include "daemon/service_notifier.hpp"
#include "daemon/station_token.hpp"
#include "daemon/web_server.hpp"
#include "geometry/atomic_file.hpp"
#include "hal/description/json_fields.hpp"

#ifndef CMMD_VERSION
#define CMMD_VERSION "0.0.0"
#endif

namespace {

using namespace cmm;
using namespace cmm::daemon;

// The log goes to stderr: stdout carries the ready line a launcher reads. Under systemd the
// journal adds time and unit; a terminal wants the time.
void set_up_logging(const std::string& level) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("cmmd"));
  if (std::getenv("JOURNAL_STREAM") != nullptr) spdlog::set_pattern("%l: %v");
  else spdlog::set_pattern("[%Y-%m-%d %H:%M:%S.%e] [%l] %v");
  spdlog::set_level(spdlog::level::from_str(level));
}

// Polls the machine off the event loop (a Modbus status can wait for its timeout), tells subscribers
// and systemd's STATUS when the link or a fault changes, and brings a lost link back when no job or
// command holds the machine. Never the watchdog: an unplugged cable must not restart cmmd.
class MachineMonitor {
 public:
  using Notify = std::function<void(const std::string& topic, const std::string& method, const nlohmann::json& params)>;

  MachineMonitor(MachineLink& machine, JobManager& jobs, Notify notify, ServiceNotifier& notifier)
      : machine_(machine), jobs_(jobs), notify_(std::move(notify)), notifier_(notifier), thread_([this] { loop(); }) {}
  ~MachineMonitor() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }

 private:
  void loop() {
    std::unique_lock lock(mutex_);
    nlohmann::json last;
    int polls = 0;
    while (!stop_) {
      lock.unlock();
      nlohmann::json s = machine_.status_json();
      if (s["link"] == "down" && polls % 4 == 0)
        if (const auto lease = machine_.try_lease(MachineLink::kReconnectHolder)) {  // never under a job or a command
          try {
            machine_.bring_up();
          } catch (const std::exception& e) {
            spdlog::debug("machine not reachable: {}", e.what());
          }
          s = machine_.status_json();  // up, or down with why: this poll reports the try just made
        }
      const nlohmann::json state = {{"lifecycle", s["lifecycle"]}, {"link", s["link"]}, {"fault", s["fault"]}};
      if (state != last) {
        spdlog::info("machine: {} ({}){}", s["link"].get<std::string>(), s["lifecycle"].get<std::string>(),
                     s["fault"].is_null() ? "" : ", " + s["fault"].value("message", s["fault"].value("kind", "")));
        notify_("machine", "machine.state", state);
        last = state;
      }
      const auto job = jobs_.running_job();
      notifier_.status("machine " + s["link"].get<std::string>() + " (" + s["lifecycle"].get<std::string>() + ")" +
                       (job ? ", running job " + std::to_string(*job) : std::string(", idle")));
      ++polls;
      lock.lock();
      wake_.wait_for(lock, std::chrono::milliseconds(500), [this] { return stop_; });
    }
  }

  MachineLink& machine_;
  JobManager& jobs_;
  Notify notify_;  // to the subscribers of both servers
  ServiceNotifier& notifier_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

// The command line's settings over the file's, at start and again on SIGHUP's reading.
using Overrides = std::function<void(DaemonConfig&)>;

int serve(const std::filesystem::path& config_file, DaemonConfig config, const Overrides& overrides) {
  set_up_logging(config.log_level);
  ServiceNotifier notifier;
  std::filesystem::create_directories(config.state_dir);
  // Before this cmmd writes any state: a cmmd killed mid-write left its temps, no later write reuses them.
  const geometry::TempSweep swept = geometry::remove_stale_atomic_temps(config.state_dir);
  if (swept.removed > 0)
    spdlog::info("removed {} temp file(s) of a write cut short in {}", swept.removed, config.state_dir.string());
  for (const std::string& problem : swept.problems) spdlog::warn("sweeping temp files: {}", problem);
  if (!config.server.unix_path.empty())
    std::filesystem::create_directories(std::filesystem::path(config.server.unix_path).parent_path());
  const std::string base_dir = config_file.empty() ? "." : config_file.parent_path().string();
  MachineLink machine(make_driver(config.driver, base_dir), config.machine, config.driver,
                      config.state_dir / "touch_in_progress.json");
  ModelStore models(config.state_dir / "models", config.models_dir);
  JobStore store(config.state_dir / "jobs");

  asio::io_context io;
  RpcDispatcher dispatcher;
  DashboardLink dashboard;  // before the servers: their handlers use it until they stop
  std::unique_ptr<StationToken> station_token;  // the same; it lives in the server's TokenBook
  std::unique_ptr<Metrics> metrics;  // counts what the notifications tell, for /metrics; outlives the servers
  std::unique_ptr<RpcServer> server;
  std::unique_ptr<WebServer> web;  // the dashboard; null with http.enabled false
  std::unique_ptr<MqttStation> fleet;  // the station on the fleet's broker; null with mqtt.enabled false
  const MachineMonitor::Notify notify = [&server, &web, &metrics, &fleet](
                                            const std::string& topic, const std::string& method,
                                            const nlohmann::json& params) {
    if (metrics) metrics->observe(method, params);
    if (server) server->notify(topic, method, params);
    if (web) web->notify(topic, method, params);
    if (fleet) fleet->notify(method, params);
  };
  JobManager jobs(config, machine, models, store, notify, CMMD_VERSION);
  Service service{config, machine, models, jobs, CMMD_VERSION};
  add_service_methods(dispatcher, service);
  add_dashboard_method(dispatcher, dashboard);
  server = std::make_unique<RpcServer>(io, dispatcher, config.server);
  // Before any listener: a TCP, WebSocket or MQTT client is operator only by a token.
  station_token = std::make_unique<StationToken>(server->tokens(), config.state_dir / "operator.token");
  std::error_code removed;
  std::filesystem::remove(config.state_dir / "dashboard.token", removed);  // earlier cmmd made a new one per start
  const std::string operator_token = station_token->set_up();
  std::atomic<int> http_port{0};  // set once the dashboard listens; a rotation before that has no URL to change
  add_station_token_method(dispatcher, *station_token, [&dashboard, &config, &http_port](const std::string& token) {
    if (const int port = http_port.load(); port != 0) dashboard.set(dashboard_url(config.server.tcp_bind, port, token));
  });
  const std::vector<std::string> methods = dispatcher.methods();  // server.auth and server.subscribe among them now
  metrics = std::make_unique<Metrics>(std::set<std::string>(methods.begin(), methods.end()));
  dispatcher.on_answered([&metrics](const std::string& method, bool error) { metrics->count_request(method, error); });
  if (config.http.enabled) {
    web = std::make_unique<WebServer>(dispatcher, server->tokens(), config.server, config.http, config.state_dir / "jobs");
    web->serve_metrics([&metrics, &server, &web, &fleet] {
      std::optional<MqttGauges> mqtt;
      if (fleet) mqtt = MqttGauges{.link_up = fleet->connected(), .unsent = static_cast<long long>(fleet->unsent())};
      return metrics->text({.socket_clients = static_cast<long long>(server->connection_count()),
                            .websocket_clients = static_cast<long long>(web->connection_count())},
                           mqtt);
    });
  }
  if (config.mqtt.enabled) {
    fleet = std::make_unique<MqttStation>(config.mqtt, CMMD_VERSION, config.state_dir, dispatcher, server->tokens(),
                                          MqttRequestLimits{.max_request_bytes = config.server.max_request_bytes,
                                                            .max_batch_entries = config.server.max_batch_entries});
  }
  server->start();
  if (web) {
    web->start();
    http_port = web->port();
    dashboard.set(dashboard_url(config.server.tcp_bind, web->port(), operator_token));
    spdlog::info("dashboard: {}", *dashboard.url());
  }
  jobs.start();
  if (fleet) {
    // After the job store's recovery: its interrupted jobs are announced by no notification.
    fleet->recall_jobs(jobs.list().at("jobs"));
    fleet->start();
  }
  MachineMonitor monitor(machine, jobs, notify, notifier);

  asio::signal_set signals(io, SIGINT, SIGTERM, SIGHUP);
  std::thread stopper;
  std::function<void(const asio::error_code&, int)> on_signal = [&](const asio::error_code& ec, int signal) {
    if (ec) return;
    if (signal == SIGHUP) {
      notifier.reloading();
      try {
        DaemonConfig next = read_daemon_config(config_file);
        overrides(next);
        for (const std::string& part : changes_needing_restart(config, next))
          spdlog::warn("SIGHUP: {} changed; it takes effect after a restart", part);
        spdlog::set_level(spdlog::level::from_str(next.log_level));
        server->set_tokens(next.server.tokens);
        spdlog::info("SIGHUP: reloaded {} (log level {}, {} token(s))", config_file.string(), next.log_level,
                     next.server.tokens.size());
      } catch (const description::FieldError& e) {
        // One line: the journal keeps each line as its own entry, and the reasons belong with the error.
        std::string problems;
        for (const std::string& line : e.lines()) problems += (problems.empty() ? "" : "; ") + line;
        spdlog::error("SIGHUP: {} refused, running on: {}", config_file.string(), problems);
      }
      notifier.ready("ready");
      signals.async_wait(on_signal);
      return;
    }
    if (stopper.joinable()) return;  // a second SIGTERM while the first is being served
    spdlog::info("signal {}: stopping the machine and shutting down", signal);
    notifier.stopping();
    // Off the event loop: a job may need a while to reach its next stop point (planning a large
    // model), and meanwhile the loop keeps answering clients and kicking the watchdog.
    stopper = std::thread([&] {
      // The job first, so the stop reads as a shutdown (the job becomes interrupted, not paused);
      // then the machine, so a manual command a worker is blocked in returns before the server joins it.
      jobs.shutdown();
      machine.count_stop();  // a manual command between two motions ends there
      try {
        machine.cmm().stop();
      } catch (const std::exception&) {
      }
      if (fleet) fleet->stop();  // after the job's last state went to the outbox; leaves with the last will
      asio::post(io, [&] {
        server->stop();
        if (web) web->stop();
        io.stop();
      });
    });
  };
  signals.async_wait(on_signal);
  notifier.start_watchdog(io);

  const nlohmann::json ready = {{"ready", true},
                                {"tcp", config.server.tcp_enabled ? nlohmann::json(server->tcp_port()) : nlohmann::json(nullptr)},
                                {"unix", config.server.unix_path},
                                {"http", web ? nlohmann::json(web->port()) : nlohmann::json(nullptr)},
                                {"state_dir", config.state_dir.string()},
                                {"driver", config.driver}};
  std::cout << ready.dump() << std::endl;
  spdlog::info("cmmd {} ready: tcp {}:{}, unix {}, state {}, driver {}", CMMD_VERSION, config.server.tcp_bind,
               server->tcp_port(), config.server.unix_path, config.state_dir.string(), config.driver);
  notifier.ready("ready; machine driver " + config.driver);
  io.run();

  if (stopper.joinable()) stopper.join();
  notifier.stop_watchdog();
  jobs.shutdown();  // already done by the signal; here for a loop that ended otherwise
  spdlog::info("cmmd stopped");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cmmd: control daemon for coordinate measuring machines (docs/api.md)"};
  std::string config_file = "/etc/cmmd/cmmd.json";
  std::string state_dir, runtime_dir;
  int tcp_port = -1, http_port = -1;
  bool check = false;
  app.add_option("-c,--config", config_file, "cmmd.json to read");
  app.add_option("--state-dir", state_dir, "state folder (overrides the config and $STATE_DIRECTORY)");
  app.add_option("--runtime-dir", runtime_dir, "folder of the Unix socket (overrides the config and $RUNTIME_DIRECTORY)");
  app.add_option("--tcp-port", tcp_port, "TCP port (0: any free one, printed in the ready line)")->check(CLI::Range(0, 65535));
  app.add_option("--http-port", http_port, "the dashboard's HTTP port (0: any free one, printed in the ready line)")
      ->check(CLI::Range(0, 65535));
  app.add_flag("--check", check, "validate the config and exit");
  app.set_version_flag("--version", std::string("cmmd ") + CMMD_VERSION);
  CLI11_PARSE(app, argc, argv);
  try {
    if (!state_dir.empty()) setenv("STATE_DIRECTORY", state_dir.c_str(), 1);
    if (!runtime_dir.empty()) setenv("RUNTIME_DIRECTORY", runtime_dir.c_str(), 1);
    const Overrides overrides = [&](DaemonConfig& c) {
      if (tcp_port >= 0) c.server.tcp_port = tcp_port;
      if (http_port >= 0) c.http.port = http_port;
    };
    DaemonConfig config = read_daemon_config(config_file);
    overrides(config);
    if (check) {
      std::cout << config_file << ": valid\n";
      return 0;
    }
    return serve(std::filesystem::absolute(config_file), std::move(config), overrides);
  } catch (const description::FieldError& e) {
    std::cerr << "cmmd: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "cmmd: " << e.what() << "\n";
    return 1;
  }
}
