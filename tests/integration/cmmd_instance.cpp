// A real cmmd process for the integration tests: its folder and config, its start and ready line,
// clients to it; and the sample scan, part and registration the job tests share.
#include "cmmd_instance.hpp"

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <stdexcept>

#include "daemon/client/model_upload.hpp"
#include "daemon/touch_journal.hpp"
#include "tests/tools/run_command.hpp"

namespace cmm::testing {

namespace {

void write_json(const std::filesystem::path& file, const nlohmann::json& j) {
  std::ofstream out(file);
  out << j.dump(1) << "\n";
  if (!out.flush()) throw std::runtime_error("cannot write " + file.string());
}

}  // namespace

CmmdInstance::CmmdInstance(std::filesystem::path folder, nlohmann::json machine, nlohmann::json extra)
    : folder_(std::move(folder)) {
  std::filesystem::create_directories(folder_);
  config_ = {{"server", {{"tcp_port", 0}, {"unix_socket", "cmmd.sock"}}},
             {"state_dir", "state"},
             {"runtime_dir", "run"},
             {"machine", std::move(machine)},
             {"log", {{"level", "warn"}}}};
  config_.merge_patch(extra);
  write_json(folder_ / "cmmd.json", config_);
}

CmmdInstance::~CmmdInstance() = default;

void CmmdInstance::start(const std::vector<std::string>& launcher, bool read_log) {
  std::vector<std::string> argv = launcher;
  // Tests run side by side: the dashboard's default port (7621) would be taken by the first.
  argv.insert(argv.end(), {CMMD_BINARY_DIR "/daemon/cmmd", "--config", (folder_ / "cmmd.json").string(), "--http-port", "0"});
  process_ = std::make_unique<ChildProcess>(argv, read_log);
  // With the log on the pipe, a restart's warnings (an interrupted job) come before the ready line.
  std::string line = process_->read_line(60);
  while (line.empty() || line.front() != '{') line = process_->read_line(60);
  const nlohmann::json ready = nlohmann::json::parse(line);
  if (!ready.value("ready", false)) throw std::runtime_error("cmmd: " + ready.dump());
  tcp_port_ = ready["tcp"].is_number() ? ready["tcp"].get<int>() : 0;
  http_port_ = ready.value("http", nlohmann::json(nullptr)).is_number() ? ready["http"].get<int>() : 0;
}

void CmmdInstance::kill9() {
  process_->signal(SIGKILL);
  process_->wait();
  process_.reset();
}

int CmmdInstance::terminate() {
  process_->signal(SIGTERM);
  const int status = process_->wait();
  process_.reset();
  return status;
}

daemon::RpcClient CmmdInstance::client() const {
  return daemon::RpcClient::connect("unix:" + (folder_ / "run" / "cmmd.sock").string());
}

daemon::RpcClient CmmdInstance::tcp_client() const {
  return daemon::RpcClient::connect("tcp://127.0.0.1:" + std::to_string(tcp_port_));
}

std::string CmmdInstance::station_token() const {
  std::ifstream in(folder_ / "state" / "operator.token");
  std::string token;
  std::getline(in, token);
  if (token.empty()) throw std::runtime_error("no station token in " + (folder_ / "state" / "operator.token").string());
  return token;
}

daemon::RpcClient CmmdInstance::operator_tcp_client() const {
  daemon::RpcClient client = tcp_client();
  client.call("server.auth", {{"token", station_token()}});
  return client;
}

std::filesystem::path CmmdInstance::job_folder(int id) const {
  char name[16];
  std::snprintf(name, sizeof name, "%06d", id);
  return folder_ / "state" / "jobs" / name;
}

int submit_job(daemon::RpcClient& client, const std::filesystem::path& model, const nlohmann::json& request) {
  nlohmann::json params = request;
  // No touch is made on an unqualified tip (docs/api.md): a job that does not say how to treat its
  // tips qualifies them itself, as a test rig that is not about qualification would be set up.
  if (!params.contains("requalify") && !params.contains("allow_unqualified_tip")) params["requalify"] = true;
  params["model"] = daemon::upload_model(client, model, 256 * 1024);
  return client.call("job.submit", params, 120).at("id").get<int>();
}

nlohmann::json wait_for_job(daemon::RpcClient& client, int job, const std::set<std::string>& states, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  client.call("server.subscribe", {{"topics", {"job"}}});
  nlohmann::json record = client.call("job.get", {{"job", job}});
  for (;;) {
    const std::string state = record.at("state").get<std::string>();
    if (states.contains(state)) return record;
    if (state == "done" || state == "failed" || state == "cancelled")
      throw std::runtime_error("job " + std::to_string(job) + " ended " + state + ": " + record.dump());
    if (std::chrono::steady_clock::now() > deadline)
      throw std::runtime_error("job " + std::to_string(job) + " still " + state + " after the timeout: " + record.dump());
    // A state change arrives as a notification; the poll catches one sent before the subscription.
    client.wait_notification(0.5);
    record = client.call("job.get", {{"job", job}});
  }
}

nlohmann::json sample_sim_block() {
  return {{"driver", "sim"},
          {"part", {{"analytic", "case3_block"}, {"edge_length_mm", 0.25}}},  // rims faceted to < 2 µm
          {"plate_pose", {{"rotation_deg", {0, 0, 7}}, {"translation", {180, 260, 0}}}},
          {"part_pose", {{"rotation_deg", {0, 0, -4}}, {"translation", {55, 25, 0}}}},
          {"trigger_sigma_mm", 0.001},
          {"seed", 7}};
}

std::filesystem::path sample_scan(const std::filesystem::path& folder) {
  const std::filesystem::path mesh = folder / "scan.ply", corners = folder / "plate_corners.json",
                              sim = folder / "sim.json";
  if (std::filesystem::exists(mesh)) return mesh;
  std::filesystem::create_directories(folder);
  write_json(sim, sample_sim_block());
  const auto r = cmm::test::run_command(std::string(CMMD_BINARY_DIR "/sim/cmm-scan") + " --sim-config " + sim.string() +
                                        " --edge-length 1 --noise 0.05 --mesh " + mesh.string() + " --plate-corners " +
                                        corners.string());
  if (r.exit_code != 0) throw std::runtime_error("cmm-scan failed: " + r.output);
  return mesh;
}

nlohmann::json timed_sim_block(double time_scale) {
  nlohmann::json block = sample_sim_block();
  block["time_scale"] = time_scale;
  return block;
}

int submit_quick_job(daemon::RpcClient& client, const std::filesystem::path& scan_folder) {
  return submit_job(client, sample_scan(scan_folder),
                    {{"spacing_mm", 8}, {"registration", sample_measure_plate(scan_folder)}});
}

nlohmann::json sample_measure_plate(const std::filesystem::path& folder) {
  sample_scan(folder);
  return {{"measure_plate", read_json_file(folder / "plate_corners.json")}};
}

namespace {
std::vector<std::string> sim_command(const std::filesystem::path& config, double time_scale, int port,
                                     const std::vector<std::string>& extra) {
  std::vector<std::string> command = {CMMD_BINARY_DIR "/sim/cmm-sim", "--config", config.string(), "--port",
                                      std::to_string(port), "--time-scale", std::to_string(time_scale)};
  command.insert(command.end(), extra.begin(), extra.end());
  return command;
}
}  // namespace

SimulatorProcess::SimulatorProcess(const std::filesystem::path& config, double time_scale, int port,
                                   const std::vector<std::string>& extra)
    : process(sim_command(config, time_scale, port, extra)) {
  const nlohmann::json ready = nlohmann::json::parse(process.read_line(60));
  this->port = ready.at("modbus_tcp").get<int>();
  ippdme_port = ready.value("ippdme", 0);
}

nlohmann::json modbus_block(int port) {
  return {{"driver", "modbus"}, {"host", "127.0.0.1"}, {"port", port}, {"connect_attempts", 3}};
}

nlohmann::json ippdme_block(int port) {
  return {{"driver", "ippdme"}, {"host", "127.0.0.1"}, {"port", port}, {"connect_attempts", 3},
          {"machine", CMMD_SOURCE_DIR "/config/machine.json"}};
}

nlohmann::json wait_for_notification(daemon::RpcClient& client, const std::string& what,
                                     const std::function<bool(const nlohmann::json&)>& match, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) throw std::runtime_error("no notification " + what + " within " + std::to_string(timeout_s) + " s");
    if (const std::optional<nlohmann::json> n = client.wait_notification(left); n && match(*n)) return *n;
  }
}

std::vector<int> journal_touch_ids(const std::filesystem::path& job_folder) {
  std::vector<int> ids;
  for (const daemon::JournalEntry& e : daemon::recover_journal(job_folder / "touches.jsonl").entries)
    ids.push_back(e.touch_id);
  return ids;
}

nlohmann::json read_json_file(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error("cannot read " + file.string());
  return nlohmann::json::parse(in);
}

}  // namespace cmm::testing
