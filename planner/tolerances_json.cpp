// Tolerances from and to JSON, with the limits a CMM's tolerances can sensibly have.
#include "planner/tolerances_json.hpp"

#include <string>

namespace cmm::planner {

namespace {

using description::JsonFields;
using nlohmann::json;

constexpr double max_tolerance_mm = 100;

// [lower, upper] with lower ≤ upper.
ToleranceZone read_zone(JsonFields& f, const ToleranceZone& fallback) {
  if (!f.present()) return fallback;
  std::vector<JsonFields> items = f.as_items();
  if (items.size() != 2) {
    if (f.value().is_array()) f.problem("must be [lower, upper] in mm");
    return fallback;
  }
  ToleranceZone zone{items[0].as_number(fallback.lower_mm, -max_tolerance_mm, max_tolerance_mm),
                     items[1].as_number(fallback.upper_mm, -max_tolerance_mm, max_tolerance_mm)};
  if (zone.lower_mm > zone.upper_mm) f.problem("lower must not exceed upper");
  return zone;
}

HoleTolerance read_hole(JsonFields& f, const HoleTolerance& fallback, const char* diameter_key, const char* position_key) {
  HoleTolerance hole = fallback;
  JsonFields diameter = f.member(diameter_key);
  hole.diameter = read_zone(diameter, fallback.diameter);
  hole.position_mm = f.number(position_key, fallback.position_mm, 0, max_tolerance_mm);
  return hole;
}

// {"<id>": value, …} with integer ids.
template <class Read>
void read_by_id(JsonFields& f, const std::string& key, Read read) {
  if (!f.has(key)) return;
  JsonFields map = f.object(key);
  if (!map.value().is_object()) return;
  for (const auto& [id_text, value] : map.value().items()) {
    std::size_t used = 0;
    int id = -1;
    try {
      id = std::stoi(id_text, &used);
    } catch (const std::exception&) {
    }
    if (used != id_text.size() || id < 0) {
      map.problem(id_text, "must be a feature id: a non-negative integer");
      continue;
    }
    JsonFields member = map.member(id_text);
    read(id, member);
  }
}

json zone_json(const ToleranceZone& zone) { return json::array({zone.lower_mm, zone.upper_mm}); }

}  // namespace

Tolerances read_tolerances(JsonFields& f, const Tolerances& defaults) {
  Tolerances t = defaults;
  if (!f.expect_object() || !f.present()) return t;
  f.known({"edge_profile_mm", "edge_points", "curves", "hole_diameter_mm", "hole_position_mm", "holes",
           "coverage_factor", "machine_uncertainty_mm"});
  t.edge_profile_mm = f.number("edge_profile_mm", defaults.edge_profile_mm, 0, max_tolerance_mm);
  read_by_id(f, "edge_points", [&](int id, JsonFields& v) { t.edge_point_profile_mm[id] = v.as_number(0, 0, max_tolerance_mm); });
  read_by_id(f, "curves", [&](int id, JsonFields& v) { t.curve_profile_mm[id] = v.as_number(0, 0, max_tolerance_mm); });
  t.hole = read_hole(f, defaults.hole, "hole_diameter_mm", "hole_position_mm");
  read_by_id(f, "holes", [&](int id, JsonFields& v) {
    if (!v.expect_object()) return;
    v.known({"diameter_mm", "position_mm"});
    t.hole_overrides[id] = read_hole(v, t.hole, "diameter_mm", "position_mm");
    v.finish();
  });
  t.coverage_factor = f.number("coverage_factor", defaults.coverage_factor, 1, 3);
  t.machine_uncertainty_mm = f.number("machine_uncertainty_mm", defaults.machine_uncertainty_mm, 0, 1);
  f.finish();
  return t;
}

json to_json(const Tolerances& t) {
  json points = json::object(), curves = json::object(), holes = json::object();
  for (const auto& [id, value] : t.edge_point_profile_mm) points[std::to_string(id)] = value;
  for (const auto& [id, value] : t.curve_profile_mm) curves[std::to_string(id)] = value;
  for (const auto& [id, hole] : t.hole_overrides)
    holes[std::to_string(id)] = {{"diameter_mm", zone_json(hole.diameter)}, {"position_mm", hole.position_mm}};
  return {{"edge_profile_mm", t.edge_profile_mm},
          {"edge_points", std::move(points)},
          {"curves", std::move(curves)},
          {"hole_diameter_mm", zone_json(t.hole.diameter)},
          {"hole_position_mm", t.hole.position_mm},
          {"holes", std::move(holes)},
          {"coverage_factor", t.coverage_factor},
          {"machine_uncertainty_mm", t.machine_uncertainty_mm}};
}

}  // namespace cmm::planner
