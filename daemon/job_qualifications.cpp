// qualifications.json: reading, writing and comparing the qualifications a job's touches rest on.
#include "daemon/job_qualifications.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "hal/description/eigen_json.hpp"

namespace cmm::daemon {

namespace {

constexpr double same_mm = 1e-7;

}  // namespace

QualificationInForce in_force(const description::StylusTip& tip, std::string source) {
  QualificationInForce q;
  q.tip = tip.id;
  q.ball_radius_mm = tip.ball_radius_mm;
  q.offset = tip.offset;
  q.qualification = tip.qualification;
  q.source = std::move(source);
  return q;
}

std::optional<int> JobQualifications::current(const std::string& tip_id) const {
  for (std::size_t i = list.size(); i-- > 0;)
    if (list[i].tip == tip_id) return static_cast<int>(i);
  return std::nullopt;
}

bool same_qualification(const QualificationInForce& a, const description::StylusTip& now) {
  if (a.tip != now.id) return false;
  if (std::abs(a.ball_radius_mm - now.ball_radius_mm) > same_mm) return false;
  if (((a.offset - now.offset).array().abs() > same_mm).any()) return false;
  if (a.qualification.has_value() != now.qualification.has_value()) return false;
  return !a.qualification || a.qualification->time_utc == now.qualification->time_utc;
}

std::string describe(const QualificationInForce& q) {
  char radius[64];
  std::snprintf(radius, sizeof radius, "r %.6f mm", q.ball_radius_mm);
  if (!q.qualification) return std::string(radius) + " nominal (never qualified)";
  return std::string(radius) + ", qualified " + q.qualification->time_utc;
}

nlohmann::json to_json(const JobQualifications& q) {
  nlohmann::json list = nlohmann::json::array();
  for (std::size_t i = 0; i < q.list.size(); ++i) {
    const QualificationInForce& e = q.list[i];
    nlohmann::json qualification = nullptr;
    if (e.qualification)
      qualification = {{"time_utc", e.qualification->time_utc},
                       {"ball_radius_mm", e.qualification->ball_radius_mm},
                       {"offset", description::vec3_json(e.qualification->offset)},
                       {"residual_rms_mm", e.qualification->residual_rms_mm},
                       {"touches", e.qualification->touches}};
    list.push_back({{"index", i},
                    {"tip", e.tip},
                    {"ball_radius_mm", e.ball_radius_mm},
                    {"offset", description::vec3_json(e.offset)},
                    {"qualification", qualification},
                    {"source", e.source},
                    {"since_utc", e.since_utc}});
  }
  nlohmann::json j = {{"tip", q.tip}, {"qualifications", list}};
  if (q.fitting) j["fitting"] = {{"tip", *q.fitting}, {"since_utc", q.fitting_since_utc}};
  return j;
}

JobQualifications job_qualifications_from_json(const nlohmann::json& j) {
  JobQualifications q;
  q.tip = j.at("tip").get<std::string>();
  for (const nlohmann::json& e : j.at("qualifications")) {
    QualificationInForce entry;
    entry.tip = e.value("tip", q.tip);  // files from before a job could use several tips name only the job's
    entry.ball_radius_mm = e.at("ball_radius_mm").get<double>();
    entry.offset = description::vec3_from_json(e.at("offset"));
    if (const nlohmann::json& k = e.at("qualification"); !k.is_null()) {
      description::TipQualification t;
      t.time_utc = k.at("time_utc").get<std::string>();
      t.ball_radius_mm = k.at("ball_radius_mm").get<double>();
      t.offset = description::vec3_from_json(k.at("offset"));
      t.residual_rms_mm = k.at("residual_rms_mm").get<double>();
      t.touches = k.at("touches").get<int>();
      entry.qualification = t;
    }
    entry.source = e.at("source").get<std::string>();
    entry.since_utc = e.at("since_utc").get<std::string>();
    q.list.push_back(std::move(entry));
  }
  if (const auto f = j.find("fitting"); f != j.end() && !f->is_null()) {
    q.fitting = f->at("tip").get<std::string>();
    q.fitting_since_utc = f->at("since_utc").get<std::string>();
  }
  if (q.list.empty()) throw std::invalid_argument("lists no qualification");
  return q;
}

}  // namespace cmm::daemon
