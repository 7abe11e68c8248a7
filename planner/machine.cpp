// Reading and checking machine.json; see machine.hpp.
#include "planner/machine.hpp"

#include <cmath>
#include <fstream>
#include <stdexcept>

#include "geometry/file_error.hpp"
#include "planner/json_fields.hpp"

namespace cmm::planner {
namespace detail {
extern const char* const default_machine_json;
}

namespace {

[[noreturn]] void fail(const std::string& source, const std::string& field, const std::string& what) {
  fail_field(source, field, what);
}

const nlohmann::json& member(const nlohmann::json& j, const char* key, const std::string& source,
                             const std::string& path) {
  if (!j.is_object() || !j.contains(key)) fail(source, path + key, "missing");
  return j.at(key);
}


Vec3 vector(const nlohmann::json& j, const std::string& source, const std::string& field) {
  if (!j.is_array() || j.size() != 3) fail(source, field, "expected [x, y, z], got " + j.dump());
  return {number(j[0], source, field + "[0]"), number(j[1], source, field + "[1]"), number(j[2], source, field + "[2]")};
}

nlohmann::json array(const Vec3& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); }

StylusTip tip_from_json(const nlohmann::json& j, const std::string& source, const std::string& at) {
  if (!j.is_object()) fail(source, at.substr(0, at.size() - 1), "expected an object");
  StylusTip tip;
  only_known_keys(j, source, at.substr(0, at.size() - 1),
                  {"id", "ball_radius_mm", "offset", "shaft_radius_mm", "shaft_length_mm", "direction", "head_radius_mm"});
  const auto& id = member(j, "id", source, at);
  if (!id.is_string() || id.get<std::string>().empty()) fail(source, at + "id", "expected a non-empty string");
  tip.id = id.get<std::string>();
  tip.ball_radius_mm = positive(member(j, "ball_radius_mm", source, at), source, at + "ball_radius_mm");
  if (j.contains("offset")) tip.offset = vector(j["offset"], source, at + "offset");
  tip.shaft_radius_mm = positive(member(j, "shaft_radius_mm", source, at), source, at + "shaft_radius_mm");
  tip.shaft_length_mm = positive(member(j, "shaft_length_mm", source, at), source, at + "shaft_length_mm");
  if (j.contains("direction")) {
    tip.direction = vector(j["direction"], source, at + "direction");
    if (tip.direction.norm() < 1e-9) fail(source, at + "direction", "is zero");
    tip.direction.normalize();
  }
  if (j.contains("head_radius_mm")) tip.head_radius_mm = positive(j["head_radius_mm"], source, at + "head_radius_mm");
  if (const std::string why = tip_problem(tip); !why.empty()) {
    const std::size_t colon = why.find(':');  // "field: why"
    fail(source, at + why.substr(0, colon), why.substr(colon + 2));
  }
  return tip;
}

}  // namespace

std::string tip_problem(const StylusTip& tip) {
  if (tip.shaft_radius_mm > tip.ball_radius_mm) return "shaft_radius_mm: is wider than the ball: the shaft would touch first";
  if (tip.shaft_length_mm <= tip.ball_radius_mm) return "shaft_length_mm: does not reach past the ball";
  return {};
}

const StylusTip& MachineDescription::tip() const {
  for (const StylusTip& t : tips)
    if (t.id == active_tip) return t;
  throw std::runtime_error("machine description: active tip \"" + active_tip + "\" is not among the tips");
}

MachineDescription machine_from_json(const nlohmann::json& j, const std::string& source) {
  if (!j.is_object()) fail(source, "(top level)", "expected an object");
  MachineDescription m;
  only_known_keys(j, source, "",
                  {"name", "description", "travel_box", "max_speed_mm_s", "max_accel_mm_s2", "probe_speed_mm_s",
                   "clearance_z", "tips", "active_tip", "reference_sphere"});
  const auto& box = member(j, "travel_box", source, "");
  if (!box.is_object()) fail(source, "travel_box", "expected an object");
  only_known_keys(box, source, "travel_box", {"min", "max"});
  m.travel_box.min = vector(member(box, "min", source, "travel_box."), source, "travel_box.min");
  m.travel_box.max = vector(member(box, "max", source, "travel_box."), source, "travel_box.max");
  if (!(m.travel_box.min.array() < m.travel_box.max.array()).all()) fail(source, "travel_box", "min must be below max on every axis");
  m.max_speed_mm_s = positive(member(j, "max_speed_mm_s", source, ""), source, "max_speed_mm_s");
  m.max_accel_mm_s2 = positive(member(j, "max_accel_mm_s2", source, ""), source, "max_accel_mm_s2");
  if (j.contains("probe_speed_mm_s")) m.probe_speed_mm_s = positive(j["probe_speed_mm_s"], source, "probe_speed_mm_s");
  if (m.probe_speed_mm_s > m.max_speed_mm_s) fail(source, "probe_speed_mm_s", "exceeds max_speed_mm_s");
  m.clearance_z = number(member(j, "clearance_z", source, ""), source, "clearance_z");
  if (m.clearance_z < m.travel_box.min.z() || m.clearance_z > m.travel_box.max.z())
    fail(source, "clearance_z", "lies outside the travel box");
  const auto& tips = member(j, "tips", source, "");
  if (!tips.is_array() || tips.empty()) fail(source, "tips", "expected a non-empty array");
  for (std::size_t i = 0; i < tips.size(); ++i) {
    const std::string at = "tips[" + std::to_string(i) + "].";
    m.tips.push_back(tip_from_json(tips[i], source, at));
    for (std::size_t k = 0; k + 1 < m.tips.size(); ++k)
      if (m.tips[k].id == m.tips.back().id) fail(source, at + "id", "duplicates tip \"" + m.tips[k].id + "\"");
  }
  const auto& active = member(j, "active_tip", source, "");
  if (!active.is_string()) fail(source, "active_tip", "expected a string");
  m.active_tip = active.get<std::string>();
  try {
    (void)m.tip();
  } catch (const std::exception&) {
    fail(source, "active_tip", "\"" + m.active_tip + "\" is not among the tips");
  }
  if (j.contains("reference_sphere")) {
    const auto& sphere = j["reference_sphere"];
    if (!sphere.is_object()) fail(source, "reference_sphere", "expected an object");
    only_known_keys(sphere, source, "reference_sphere", {"centre", "radius_mm"});
    m.reference_sphere.centre = vector(member(sphere, "centre", source, "reference_sphere."), source, "reference_sphere.centre");
    m.reference_sphere.radius_mm =
        positive(member(sphere, "radius_mm", source, "reference_sphere."), source, "reference_sphere.radius_mm");
  }
  return m;
}

MachineDescription read_machine(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw geometry::FileError::whole(file, "cannot open the machine description");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {  // out_of_range too: a number like 1e400
    throw geometry::FileError::whole(file, std::string("not valid JSON (") + e.what() + ")");
  }
  return machine_from_json(j, file.string());
}

nlohmann::json to_json(const MachineDescription& m) {
  nlohmann::json tips = nlohmann::json::array();
  for (const StylusTip& t : m.tips)
    tips.push_back({{"id", t.id},
                    {"ball_radius_mm", t.ball_radius_mm},
                    {"offset", array(t.offset)},
                    {"shaft_radius_mm", t.shaft_radius_mm},
                    {"shaft_length_mm", t.shaft_length_mm},
                    {"direction", array(t.direction)},
                    {"head_radius_mm", t.head_radius_mm}});
  return {{"travel_box", {{"min", array(m.travel_box.min)}, {"max", array(m.travel_box.max)}}},
          {"max_speed_mm_s", m.max_speed_mm_s},
          {"max_accel_mm_s2", m.max_accel_mm_s2},
          {"probe_speed_mm_s", m.probe_speed_mm_s},
          {"clearance_z", m.clearance_z},
          {"tips", tips},
          {"active_tip", m.active_tip},
          {"reference_sphere", {{"centre", array(m.reference_sphere.centre)}, {"radius_mm", m.reference_sphere.radius_mm}}}};
}

MachineDescription default_machine() {
  return machine_from_json(nlohmann::json::parse(detail::default_machine_json), "config/machine.json (built in)");
}

}  // namespace cmm::planner
