// A real cmmd started by a test: its own config, state and socket folders under one temp folder, a
// restart that keeps them (for crash tests), and RPC clients over its Unix socket or TCP port.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "daemon/client/rpc_client.hpp"

namespace cmm::testing {

class CmmdInstance {
 public:
  // `machine` is cmmd.json's machine block; `extra` is merged over the rest of the config.
  CmmdInstance(std::filesystem::path folder, nlohmann::json machine, nlohmann::json extra = nlohmann::json::object());
  ~CmmdInstance();

  // Spawns cmmd (its dashboard on an ephemeral port: --http-port 0) and waits for its ready line.
  // `launcher` goes before cmmd's own command line (e.g. a shell that sets the environment and
  // execs it, so cmmd keeps the pid the test knows).
  // read_log: cmmd's log (stderr) comes through process().read_line after the ready line.
  void start(const std::vector<std::string>& launcher = {}, bool read_log = false);
  void kill9();             // SIGKILL, reaped
  int terminate();          // SIGTERM; its exit status
  bool running() const { return process_ != nullptr; }
  ChildProcess& process() { return *process_; }

  daemon::RpcClient client() const;      // over the Unix socket (operator)
  daemon::RpcClient tcp_client() const;           // over TCP, not authenticated: role none
  daemon::RpcClient operator_tcp_client() const;  // over TCP, authenticated by the station token
  std::string station_token() const;              // <state_dir>/operator.token
  int tcp_port() const { return tcp_port_; }
  int http_port() const { return http_port_; }  // the dashboard's; 0 when http.enabled is false
  const std::filesystem::path& folder() const { return folder_; }
  std::filesystem::path job_folder(int id) const;
  const nlohmann::json& config() const { return config_; }

 private:
  std::filesystem::path folder_;
  nlohmann::json config_;
  std::unique_ptr<ChildProcess> process_;
  int tcp_port_ = 0;
  int http_port_ = 0;
};

// Uploads a file and submits a job on it; returns the job id.
int submit_job(daemon::RpcClient& client, const std::filesystem::path& model, const nlohmann::json& request);

// Polls job.get until the job is in one of `states` (or final, which then must be one of them);
// returns its record. Throws std::runtime_error with the record after timeout_s.
nlohmann::json wait_for_job(daemon::RpcClient& client, int job, const std::set<std::string>& states, double timeout_s);

// The simulator's sample setup shared by the daemon tests: case-3 block on the default plate.
nlohmann::json sample_sim_block();
// sample_sim_block with its motion in wall time / time_scale.
nlohmann::json timed_sim_block(double time_scale);
// A job on the sample scan with 8 mm spacing and the plate measured: a few seconds of probing at
// time_scale 50. Returns its id.
int submit_quick_job(daemon::RpcClient& client, const std::filesystem::path& scan_folder);
// The measure_plate registration for sample_sim_block, as cmm-scan --plate-corners would write it.
nlohmann::json sample_measure_plate(const std::filesystem::path& folder);
// A scanned reference mesh of the sample part (cmm-scan), written once into `folder`.
std::filesystem::path sample_scan(const std::filesystem::path& folder);

// cmm-sim on loopback serving `config` over Modbus TCP; `port` 0 lets it pick one (see port).
// `extra` goes on its command line: {"--ippdme", "0"} serves I++ DME too (see ippdme_port).
struct SimulatorProcess {
  SimulatorProcess(const std::filesystem::path& config, double time_scale, int port = 0,
                   const std::vector<std::string>& extra = {});
  ChildProcess process;
  int port = 0;
  int ippdme_port = 0;
};
// cmmd.json's machine block for a cmm-sim on 127.0.0.1:port.
nlohmann::json modbus_block(int port);
// cmmd.json's machine block for cmm-sim's I++ DME server on 127.0.0.1:port (the default machine).
nlohmann::json ippdme_block(int port);

// The next notification (as {"method", "params"}) that `match` accepts, the others dropped; throws
// std::runtime_error naming `what` after timeout_s.
nlohmann::json wait_for_notification(daemon::RpcClient& client, const std::string& what,
                                     const std::function<bool(const nlohmann::json&)>& match, double timeout_s);
// The touch ids of a job's touches.jsonl in file order (a torn last line left out).
std::vector<int> journal_touch_ids(const std::filesystem::path& job_folder);
// A JSON file's contents; std::runtime_error naming the file when it cannot be read.
nlohmann::json read_json_file(const std::filesystem::path& file);

}  // namespace cmm::testing
