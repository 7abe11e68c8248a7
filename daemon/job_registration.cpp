// registration.json: written once per registration, read back on every resume.
#include "daemon/job_registration.hpp"

#include <stdexcept>

#include "hal/description/eigen_json.hpp"

namespace cmm::daemon {

const char* to_string(JobRegistration::Method method) {
  return method == JobRegistration::Method::measured ? "measured" : "given";
}

namespace {
nlohmann::json tips_json(const std::vector<PlannedTip>& tips) {
  nlohmann::json j = nlohmann::json::array();
  for (const PlannedTip& t : tips) j.push_back({{"id", t.id}, {"radius_mm", t.radius_mm}});
  return j;
}
}  // namespace

nlohmann::json to_json(const JobRegistration& r) {
  nlohmann::json j = {{"method", to_string(r.method)},
                      {"T_M_S", description::transform_json(r.T_M_S)},
                      {"radius_mm", r.radius_mm},
                      {"tip", r.tip},
                      {"tips", tips_json(r.tips)},
                      {"time_utc", r.time_utc},
                      {"registration", r.fit}};
  if (r.method == JobRegistration::Method::measured) {
    nlohmann::json corners = nlohmann::json::array();
    for (const MeasuredCorner& c : r.measured_corners)
      corners.push_back({{"id", c.id},
                         {"machine", description::vec3_json(c.machine)},
                         {"face_rms_mm", c.face_rms_mm},
                         {"conditioning", c.conditioning}});
    j["corner_touches"] = r.corner_touches;
    j["measured_corners"] = corners;
  }
  return j;
}

JobRegistration job_registration_from_json(const nlohmann::json& j) {
  JobRegistration r;
  const std::string method = j.at("method").get<std::string>();
  if (method != "given" && method != "measured") throw std::invalid_argument("unknown registration method \"" + method + "\"");
  r.method = method == "measured" ? JobRegistration::Method::measured : JobRegistration::Method::given;
  r.T_M_S = description::transform_from_json(j.at("T_M_S"));
  r.radius_mm = j.at("radius_mm").get<double>();
  r.tip = j.at("tip").get<std::string>();
  // A job registered before jobs could use several tips plans with its one tip.
  for (const nlohmann::json& t : j.value("tips", nlohmann::json::array()))
    r.tips.push_back({t.at("id").get<std::string>(), t.at("radius_mm").get<double>()});
  if (r.tips.empty()) r.tips.push_back({r.tip, r.radius_mm});
  r.time_utc = j.value("time_utc", "");
  r.fit = j.value("registration", nlohmann::json(nullptr));
  r.corner_touches = j.value("corner_touches", 0);
  for (const nlohmann::json& c : j.value("measured_corners", nlohmann::json::array()))
    r.measured_corners.push_back({c.at("id").get<int>(), description::vec3_from_json(c.at("machine")),
                                  c.at("face_rms_mm").get<std::array<double, 3>>(), c.at("conditioning").get<double>()});
  return r;
}

}  // namespace cmm::daemon
