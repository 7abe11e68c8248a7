#include "daemon/job_request.hpp"

#include <cmath>
#include <cstdint>
#include <set>

#include "daemon/rpc_error.hpp"
#include "geometry/file_error.hpp"

namespace cmm::daemon {

namespace {

double number(const nlohmann::json& j, const char* key, double fallback, double min, double max) {
  if (!j.contains(key)) return fallback;
  const nlohmann::json& v = j.at(key);
  const std::string path = std::string("/") + key;
  if (!v.is_number()) throw_invalid_param(path, "must be a number");
  const double x = v.get<double>();
  if (!std::isfinite(x) || x < min || x > max)
    throw_invalid_param(path, "must be in [" + std::to_string(min) + ", " + std::to_string(max) + "]");
  return x;
}

planner::Vec3 vec3(const nlohmann::json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 3) throw_invalid_param(path, "must be [x, y, z]");
  planner::Vec3 v;
  for (int i = 0; i < 3; ++i) {
    if (!j[static_cast<std::size_t>(i)].is_number()) throw_invalid_param(path + "/" + std::to_string(i), "must be a number");
    v[i] = j[static_cast<std::size_t>(i)].get<double>();
    if (!std::isfinite(v[i])) throw_invalid_param(path + "/" + std::to_string(i), "must be finite");
  }
  return v;
}

// [{"id", key: [x, y, z]}, …] → ids and points.
void corner_list(const nlohmann::json& j, const std::string& path, const char* key, std::vector<int>& ids,
                 std::vector<planner::Vec3>& points) {
  if (!j.is_array()) throw_invalid_param(path, std::string("must be an array of {\"id\", \"") + key + "\"}");
  for (std::size_t i = 0; i < j.size(); ++i) {
    const std::string at = path + "/" + std::to_string(i);
    if (!j[i].is_object() || !j[i].contains("id") || !j[i]["id"].is_number_integer())
      throw_invalid_param(at + "/id", "must be an integer corner id");
    if (!j[i].contains(key)) throw_invalid_param(at + "/" + key, "is missing");
    // Out of int's range is no corner (plate_measurement names the valid ids); not narrowed to one.
    const nlohmann::json& id = j[i]["id"];
    const bool fits = id.is_number_unsigned() ? id.get<std::uint64_t>() <= 1000000 : id.get<std::int64_t>() >= -1000000 && id.get<std::int64_t>() <= 1000000;
    ids.push_back(fits ? id.get<int>() : -1);
    points.push_back(vec3(j[i][key], at + "/" + key));
  }
}

PlateMeasurement plate_measurement(const nlohmann::json& j, const planner::Plate& plate) {
  const std::string path = "/registration/measure_plate";
  if (!j.is_object()) throw_invalid_param(path, "must be an object");
  for (const auto& [key, value] : j.items())
    if (key != "scan_corners" && key != "rough_machine" && key != "plate") throw_invalid_param(path + "/" + key, "unknown field");
  PlateMeasurement m;
  if (!j.contains("scan_corners") || !j.contains("rough_machine"))
    throw_invalid_param(path, "needs \"scan_corners\" and \"rough_machine\"");
  corner_list(j["scan_corners"], path + "/scan_corners", "scan", m.ids, m.scan);
  std::vector<int> rough_ids;
  corner_list(j["rough_machine"], path + "/rough_machine", "machine", rough_ids, m.rough_machine);
  if (rough_ids != m.ids) throw_invalid_param(path + "/rough_machine", "must name the same corners as scan_corners, in the same order");
  std::set<int> seen;
  for (std::size_t i = 0; i < m.ids.size(); ++i) {
    const int id = m.ids[i];
    if (id < 1 || id > plate.corner_count() || !seen.insert(id).second)
      throw_invalid_param(path + "/scan_corners/" + std::to_string(i) + "/id",
          "must be a distinct corner of the plate (1 to " + std::to_string(plate.corner_count()) + ")");
  }
  if (m.ids.size() < 3) throw_invalid_param(path + "/scan_corners", "needs at least three corners");
  return m;
}

}  // namespace

JobRequest parse_job_request(const nlohmann::json& params, const DaemonConfig& config, bool registration_optional) {
  if (!params.is_object()) throw_invalid_param("", "the job request must be an object");
  static const std::set<std::string> known = {"model", "name", "scale", "delta_mm", "spacing_mm",
                                              "feature_angle_deg", "seed", "requalify", "registration"};
  for (const auto& [key, value] : params.items())
    if (!known.contains(key)) throw_invalid_param("/" + key, "unknown field");
  JobRequest r;
  if (!params.contains("model") || !params["model"].is_string()) throw_invalid_param("/model", "must be \"sha256:<hex>\" or \"file:<name>\"");
  r.model = params["model"].get<std::string>();
  if (r.model.rfind("sha256:", 0) != 0 && r.model.rfind("file:", 0) != 0)
    throw_invalid_param("/model", "must be \"sha256:<hex>\" or \"file:<name>\"");
  if (params.contains("name")) {
    if (!params["name"].is_string()) throw_invalid_param("/name", "must be a string");
    r.name = params["name"].get<std::string>();
  }
  // A unit conversion (µm, inch, m to mm) lies well inside; the model's size against the travel
  // box is checked when it is loaded, before any work that grows with it.
  r.scale = number(params, "scale", 1, 1e-4, 1e4);
  r.delta_mm = number(params, "delta_mm", config.job.delta_mm, 0.001, 10);
  r.spacing_mm = number(params, "spacing_mm", config.job.spacing_mm, 0.05, 100);
  r.feature_angle_deg = number(params, "feature_angle_deg", config.job.feature_angle_deg, 1, 179);
  r.seed = static_cast<std::uint64_t>(number(params, "seed", 1, 0, 9007199254740992.0));
  if (params.contains("requalify")) {
    if (!params["requalify"].is_boolean()) throw_invalid_param("/requalify", "must be true or false");
    r.requalify = params["requalify"].get<bool>();
  }
  r.plate = config.plate;
  if (registration_optional && !params.contains("registration")) return r;

  if (!params.contains("registration") || !params["registration"].is_object())
    throw_invalid_param("/registration", "must be {\"corners\": [...]} or {\"measure_plate\": {...}}");
  const nlohmann::json& reg = params["registration"];
  if (reg.contains("measure_plate") == reg.contains("corners"))
    throw_invalid_param("/registration", "needs exactly one of \"corners\" and \"measure_plate\"");
  const bool measured = reg.contains("measure_plate") && reg["measure_plate"].is_object() &&
                        reg["measure_plate"].contains("plate");
  const nlohmann::json* plate = measured ? &reg["measure_plate"]["plate"] : reg.contains("plate") ? &reg["plate"] : nullptr;
  const std::string plate_path = measured ? "/registration/measure_plate/plate" : "/registration/plate";
  if (plate != nullptr) {
    if (!plate->is_object()) throw_invalid_param(plate_path, "must be a plate object (docs/registration.md)");
    try {
      r.plate = planner::plate_from_json(*plate, "job request " + plate_path);
    } catch (const geometry::FileError& e) {
      throw_invalid_param(plate_path + e.json_pointer(), e.what());
    } catch (const std::exception& e) {
      throw_invalid_param(plate_path, e.what());
    }
  }
  if (reg.contains("measure_plate")) {
    r.measure = plate_measurement(reg["measure_plate"], r.plate);
  } else {
    try {
      nlohmann::json given = reg;
      given["plate"] = planner::to_json(r.plate);
      r.given = planner::registration_from_json(given, "job request /registration");
    } catch (const geometry::FileError& e) {
      throw_invalid_param("/registration" + e.json_pointer(), e.what());
    } catch (const std::exception& e) {
      throw_invalid_param("/registration", e.what());
    }
  }
  return r;
}

}  // namespace cmm::daemon
