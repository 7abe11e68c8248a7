// The job record's JSON, field by field as docs/api.md lists them.
#include "daemon/job_record.hpp"

namespace cmm::daemon {

void to_json(nlohmann::json& j, const JobProgress& p) {
  j = {{"phase", p.phase}, {"done", p.done}, {"total", p.total}, {"eta_s", p.eta_s}};
}

void from_json(const nlohmann::json& j, JobProgress& p) {
  j.at("phase").get_to(p.phase);
  j.at("done").get_to(p.done);
  j.at("total").get_to(p.total);
  j.at("eta_s").get_to(p.eta_s);
}

void to_json(nlohmann::json& j, const JobFault& f) { j = {{"kind", f.kind}, {"message", f.message}}; }

void from_json(const nlohmann::json& j, JobFault& f) {
  j.at("kind").get_to(f.kind);
  j.at("message").get_to(f.message);
}

void to_json(nlohmann::json& j, const JobRecord& r) {
  j = {{"id", r.id},           {"name", r.name},       {"state", to_string(r.state)},
       {"reason", r.reason},   {"model", r.model},     {"created", r.created},
       {"updated", r.updated}, {"progress", r.progress}, {"fault", nullptr}, {"verdict", r.verdict}};
  if (r.fault) j["fault"] = *r.fault;
}

void from_json(const nlohmann::json& j, JobRecord& r) {
  j.at("id").get_to(r.id);
  j.at("name").get_to(r.name);
  r.state = job_state_from_string(j.at("state").get<std::string>());
  j.at("reason").get_to(r.reason);
  j.at("model").get_to(r.model);
  j.at("created").get_to(r.created);
  j.at("updated").get_to(r.updated);
  j.at("progress").get_to(r.progress);
  const auto& fault = j.at("fault");
  r.fault = fault.is_null() ? std::nullopt : std::optional<JobFault>(fault.get<JobFault>());
  r.verdict = j.value("verdict", nlohmann::json(nullptr));  // records from before verdicts have none
}

}  // namespace cmm::daemon
