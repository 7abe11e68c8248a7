#include "daemon/job_result.hpp"

#include <cstdio>

#include "daemon/sha256.hpp"
#include "planner/measured_cloud.hpp"
#include "planner/plan_compensation.hpp"
#include "planner/result_csv.hpp"
#include "planner/result_json.hpp"

namespace cmm::daemon {

namespace {

std::string sha256_of(std::string_view text) {
  Sha256 digest;
  digest.update(text);
  return digest.hex_digest();
}

// What a result needs to be traced back to: which software, config, machine, tip and inputs.
nlohmann::json traceability(const JobResultInputs& in) {
  std::string config_hash;
  try {
    config_hash = sha256_hex_of_file(in.config.source);
  } catch (const std::exception&) {
    config_hash = "";  // cmmd started from defaults, not a file
  }
  nlohmann::json qualification = nullptr;
  if (in.tip.qualification)
    qualification = {{"time_utc", in.tip.qualification->time_utc},
                     {"ball_radius_mm", in.tip.qualification->ball_radius_mm},
                     {"residual_rms_mm", in.tip.qualification->residual_rms_mm}};
  return {{"cmmd_version", in.version},
          {"config_file", in.config.source.string()},
          {"config_sha256", config_hash},
          {"machine_description_sha256", sha256_of(planner::to_json(in.machine).dump())},
          {"driver", in.config.driver},
          {"model", in.request.model},
          {"model_file", in.model.inputs.model_file.string()},
          {"tip", {{"id", in.tip.id}, {"qualification", qualification}}},
          {"seeds", {{"job", in.request.seed}, {"machine", in.config.machine.value("seed", nlohmann::json(nullptr))}}},
          {"started_utc", in.started_utc},
          {"finished_utc", in.finished_utc}};
}

}  // namespace

std::string write_job_result(JobStore& store, int job_id, const JobResultInputs& in) {
  std::map<int, planner::TouchOutcome> outcomes;
  for (const auto& [id, r] : in.touches) outcomes[id] = {r.contact, r.centre};
  const double radius = in.machine.tip().ball_radius_mm;
  const planner::MeasurementResult result = planner::compensate_plan(
      in.model.features, in.plan, in.T_M_S, outcomes, {radius, in.config.job.trigger_sigma_mm});

  nlohmann::json j = planner::to_json(result);
  j["job"] = job_id;
  j["touches"] = in.touches.size();
  j["machine_time_s"] = in.machine_time_s;
  j["name"] = in.request.name;
  j["registration"] = in.registration.value("registration", nlohmann::json(nullptr));
  j["registration_method"] = in.registration.value("method", "");
  j["traceability"] = traceability(in);
  j["files"] = {{"csv", "result.csv"}, {"holes_csv", "result.holes.csv"}, {"merged_cloud", "merged.ply"},
                {"plan", "plan.json"}, {"touches", "touches.jsonl"}};
  store.write_file(job_id, "result.csv", planner::to_csv(result));
  store.write_file(job_id, "result.holes.csv", planner::holes_to_csv(result));
  geometry::Points scan_points = in.model.mesh.vertices;
  planner::write_merged_ply(store.folder(job_id) / "merged.ply", scan_points, planner::measured_points_in_scan(result),
                            in.request.delta_mm);  // δ bounds a reference point's error
  store.write_file(job_id, "result.json", j.dump(1) + "\n");

  const planner::ResultSummary& s = result.summary;
  char line[256];
  std::snprintf(line, sizeof line,
                "%d of %d edge points measured (%d failed); deviation RMS %.4f mm, max %.4f mm; %d of %d holes measured",
                s.edges_measured, s.edge_points, s.edges_failed, s.rms_deviation_mm, s.max_deviation_mm,
                s.holes_measured, s.holes);
  return line;
}

}  // namespace cmm::daemon
