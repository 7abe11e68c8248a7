// cmmd.json: where cmmd listens, keeps its state and finds its machine, read in one pass that names
// every bad key by its JSON Pointer (defaults in config/cmmd.json; DESIGN.md, Files).
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "daemon/driver_factory.hpp"
#include "daemon/rpc_server.hpp"
#include "hal/description/machine_description.hpp"
#include "hal/description/plate.hpp"

namespace cmm::daemon {

// What a job takes when its request leaves a value out.
struct JobDefaults {
  double delta_mm = 0.2;
  double spacing_mm = 2;
  double feature_angle_deg = 30;
  double trigger_sigma_mm = 0.001;  // 1-σ of a trigger centre, for the uncertainties in the result
};

struct DaemonConfig {
  std::filesystem::path source;       // the file read ("<defaults>" without one)
  ServerOptions server;               // unix_path resolved against runtime_dir
  std::filesystem::path state_dir;    // models/, jobs/; $STATE_DIRECTORY overrides
  std::filesystem::path runtime_dir;  // the Unix socket; $RUNTIME_DIRECTORY overrides
  std::filesystem::path models_dir;   // read-only folder a job may name as "file:<name>"; empty: none
  std::string log_level = "info";     // spdlog level name
  nlohmann::json machine = nlohmann::json::object();  // the driver's block, handed to hal::Cmm::configure
  std::string driver = default_driver_name();         // one of driver_factory.hpp's
  description::MachineDescription description;  // what jobs are planned for (tips' radii from the machine)
  description::Plate plate;               // the base plate jobs register by
  JobDefaults job;
};

// Reads `file`; relative paths in it resolve against its folder. Throws description::FieldError
// listing every problem ("cmmd.json: /job/delta_mm: must be in [0.001, 10], not 20").
DaemonConfig read_daemon_config(const std::filesystem::path& file);
DaemonConfig daemon_config_from_json(const nlohmann::json& j, const std::string& source,
                                     const std::filesystem::path& base_dir);

// The parts of a new config that SIGHUP may apply to a running cmmd are the log level and the
// tokens; this lists what else differs, which needs a restart.
std::vector<std::string> changes_needing_restart(const DaemonConfig& running, const DaemonConfig& next);

}  // namespace cmm::daemon
