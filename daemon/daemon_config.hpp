// cmmd.json: where cmmd listens, keeps its state and finds its machine, read in one pass that names
// every bad key by its JSON Pointer (defaults in config/cmmd.json; DESIGN.md, Files).
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "daemon/driver_factory.hpp"
#include "daemon/http_options.hpp"
#include "daemon/mqtt_options.hpp"
#include "daemon/rpc_server.hpp"
#include "hal/description/machine_description.hpp"
#include "hal/description/plate.hpp"
#include "planner/inspection.hpp"

namespace cmm::daemon {

// What a job takes when its request leaves a value out.
struct JobDefaults {
  double delta_mm = 0.2;
  double spacing_mm = 2;
  double feature_angle_deg = 30;
  double trigger_sigma_mm = 0.001;  // 1-σ of a trigger centre, for the uncertainties in the result
};

// How far an operator's jog may go at once (daemon/machine_jog.hpp): the fastest a jog moves, and
// the longest one guarded segment of it runs, which bounds how late a release or a stop takes effect.
struct JogOptions {
  double max_speed_mm_s = 5;
  double segment_s = 0.1;
};

std::string default_station_name();  // the host name, or "cmmd" when it has none

struct DaemonConfig {
  std::filesystem::path source;       // the file read ("<defaults>" without one)
  ServerOptions server;               // unix_path resolved against runtime_dir
  HttpOptions http;                   // the dashboard; web_root resolved (default_web_root when unset)
  std::filesystem::path state_dir;    // models/, jobs/; $STATE_DIRECTORY overrides
  std::filesystem::path runtime_dir;  // the Unix socket; $RUNTIME_DIRECTORY overrides
  std::filesystem::path models_dir;   // read-only folder a job may name as "file:<name>"; empty: none
  std::string log_level = "info";     // spdlog level name
  nlohmann::json machine = nlohmann::json::object();  // the driver's block, handed to hal::Cmm::configure
  std::string driver = default_driver_name();         // one of driver_factory.hpp's
  description::MachineDescription description;  // what jobs are planned for (tips' radii from the machine)
  description::Plate plate;               // the base plate jobs register by
  JobDefaults job;
  JogOptions jog;
  planner::Tolerances tolerances;  // a job's, where its request gives none (planner/tolerances_json.hpp)
  // This station's name in reports and QIF files (and, later, on a fleet's broker); default the host's name.
  std::string station = default_station_name();
  MqttOptions mqtt;  // the fleet's broker; mqtt.station resolved (the station above when unset)
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
