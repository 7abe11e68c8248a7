// Reading a job request field by field with the one field checker: every bad field noted by its
// JSON Pointer, the first of them the −32602's data.path.
#include "daemon/job_request.hpp"

#include <set>

#include "daemon/client/rpc_error.hpp"
#include "daemon/model_store.hpp"
#include "hal/description/json_fields.hpp"
#include "planner/inspection_scope_json.hpp"
#include "planner/tolerances_json.hpp"

namespace cmm::daemon {

namespace {

using description::JsonFields;

// [{"id", key: [x, y, z]}, …] → ids and points.
void corner_list(JsonFields& list, const char* key, std::vector<int>& ids, std::vector<Eigen::Vector3d>& points) {
  for (JsonFields& corner : list.as_items()) {
    if (!corner.expect_object()) continue;
    // Out of int's range is no corner (the plate's ids are checked below); never narrowed to one.
    ids.push_back(corner.require("id", "an integer corner id") ? corner.integer("id", -1, -1000000, 1000000) : -1);
    points.push_back(corner.require(key) ? corner.vec3(key, Eigen::Vector3d::Zero()) : Eigen::Vector3d::Zero());
    corner.finish();
  }
}

// The "model" of `f` (the request's or its nominal's), its text checked here so that a bad one is
// refused at its own field with the others, before any model is looked up.
std::string model_ref(JsonFields& f) {
  if (!f.require("model", "\"sha256:<hex>\" or \"file:<name>\"")) return {};
  const bool text = f.value().at("model").is_string();  // else f.text notes it
  std::string ref = f.text("model", "");
  if (text)
    if (const std::optional<std::string> problem = model_ref_problem(ref)) f.problem("model", *problem);
  return ref;
}

PlateMeasurement plate_measurement(JsonFields& f, const description::Plate& plate) {
  PlateMeasurement m;
  const std::size_t problems = f.problem_count();
  if (!f.require("scan_corners") || !f.require("rough_machine")) return m;
  JsonFields scan = f.member("scan_corners"), rough = f.member("rough_machine");
  corner_list(scan, "scan", m.ids, m.scan);
  std::vector<int> rough_ids;
  corner_list(rough, "machine", rough_ids, m.rough_machine);
  if (f.problem_count() != problems) return m;
  if (rough_ids != m.ids) rough.problem("must name the same corners as scan_corners, in the same order");
  std::set<int> seen;
  for (std::size_t i = 0; i < m.ids.size(); ++i) {
    const int id = m.ids[i];
    if (id < 1 || id > plate.corner_count() || !seen.insert(id).second)
      scan.as_items()[i].problem("id", "must be a distinct corner of the plate (1 to " +
                                           std::to_string(plate.corner_count()) + ")");
  }
  if (m.ids.size() < 3) scan.problem("needs at least three corners");
  return m;
}

// An inline plate (a file name would let a client read files of the daemon's host).
void read_plate(JsonFields& f, description::Plate& plate) {
  if (!f.has("plate")) return;
  JsonFields given = f.member("plate");
  if (!given.value().is_object()) {
    given.problem("must be a plate object (docs/registration.md)");
    return;
  }
  try {
    plate = description::plate_from_json(given.value(), "job request " + given.pointer());
  } catch (const description::FieldError& e) {
    f.problems_of(e, "plate");
  }
}

}  // namespace

JobRequest parse_job_request(const nlohmann::json& params, const DaemonConfig& config, bool registration_optional) {
  JsonFields f(params);
  JobRequest r;
  const auto refuse_if_problems = [&f] {
    try {
      f.throw_if_problems("job request");
    } catch (const description::FieldError& e) {
      throw invalid_params(e);
    }
  };
  if (!f.expect_object()) refuse_if_problems();
  f.known({"model", "name", "scale", "delta_mm", "spacing_mm", "feature_angle_deg", "tolerance_mm", "bin_size_mm",
           "adaptive", "seed", "requalify", "units_checked", "tip", "allow_unqualified_tip", "registration", "nominal", "tolerances",
           "inspect"});
  r.model = model_ref(f);
  r.name = f.text("name", "");
  // A unit conversion (µm, inch, m to mm) lies well inside; the model's size against the travel
  // box is checked when it is loaded, before any work that grows with it.
  r.scale = f.number("scale", 1, 1e-4, 1e4);
  r.scale_given = f.has("scale");
  r.units_checked = f.flag("units_checked", false);
  r.delta_mm = f.number("delta_mm", config.job.delta_mm, 0.001, 10);
  r.spacing_mm = f.number("spacing_mm", config.job.spacing_mm, 0.05, 100);
  r.feature_angle_deg = f.number("feature_angle_deg", config.job.feature_angle_deg, 1, 179);
  // A micrometre to a centimetre: finer than a CMM resolves is no tolerance, and the front end's
  // memory and time are bounded by the cloud's size whatever the bin size.
  if (f.has("tolerance_mm")) r.tolerance_mm = f.number("tolerance_mm", 0.05, 0.001, 10);
  if (f.has("bin_size_mm")) r.bin_size_mm = f.number("bin_size_mm", 0.05, 0.001, 10);
  r.adaptive = f.flag("adaptive", false);
  r.seed = static_cast<std::uint64_t>(f.number("seed", 1, 0, 9007199254740992.0));
  r.requalify = f.flag("requalify", false);
  r.allow_unqualified_tip = f.flag("allow_unqualified_tip", false);
  {
    std::set<std::string> tips{"auto"};
    for (const description::StylusTip& t : config.description.tips) tips.insert(t.id);
    r.tip = f.text("tip", "auto", tips);
  }
  if (f.has("nominal")) {
    JsonFields nominal = f.object("nominal");
    if (nominal.value().is_object()) {
      NominalRequest n;
      n.model = model_ref(nominal);
      n.scale = nominal.number("scale", 1, 1e-4, 1e4);
      n.scale_given = nominal.has("scale");
      n.placement = nominal.text("placement", "given", {"given", "fit"});
      nominal.finish();
      r.nominal = n;
    }
  }
  JsonFields tolerances = f.object("tolerances");
  r.tolerances = planner::read_tolerances(tolerances, config.tolerances);
  JsonFields inspect = f.member("inspect");
  r.inspect = planner::read_inspection_scope(inspect);
  r.plate = config.plate;
  if (!(registration_optional && !f.has("registration")) &&
      f.require("registration", "{\"corners\": [...]} or {\"measure_plate\": {...}}")) {
    JsonFields reg = f.object("registration");
    if (reg.value().is_object() && reg.has("measure_plate") == reg.has("corners"))
      reg.problem("needs exactly one of \"corners\" and \"measure_plate\"");
    else if (reg.has("measure_plate")) {
      read_plate(reg, r.plate);
      JsonFields measure = reg.object("measure_plate");
      measure.known({"scan_corners", "rough_machine", "plate"});
      read_plate(measure, r.plate);
      r.measure = plate_measurement(measure, r.plate);
      measure.finish();
      reg.finish();
    } else if (reg.value().is_object()) {
      read_plate(reg, r.plate);
      nlohmann::json given = reg.value();
      given["plate"] = description::to_json(r.plate);
      try {
        r.given = planner::registration_from_json(given, "job request /registration");
      } catch (const description::FieldError& e) {
        f.problems_of(e, "registration");
      }
    }
  }
  f.finish();
  refuse_if_problems();
  return r;
}

}  // namespace cmm::daemon
