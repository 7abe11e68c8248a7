// Reading and checking machine.json; see machine_description.hpp.
#include "hal/description/machine_description.hpp"

#include <limits>
#include <stdexcept>

#include "hal/description/eigen_json.hpp"
#include "hal/description/json_fields.hpp"

namespace cmm::description {
namespace detail {
extern const char* const default_machine_json;
}

namespace {

constexpr double inf = std::numeric_limits<double>::infinity();

StylusTip read_tip(JsonFields& t) {
  const std::size_t problems_before = t.problem_count();
  StylusTip tip;
  if (t.require("id", "the tip's name")) tip.id = t.text("id", "");
  if (t.has("id") && t.value()["id"].is_string() && tip.id.empty()) t.problem("id", "must not be empty");
  if (t.require("ball_radius_mm")) tip.ball_radius_mm = t.positive("ball_radius_mm", tip.ball_radius_mm);
  tip.offset = t.vec3("offset", tip.offset);
  if (t.require("shaft_radius_mm")) tip.shaft_radius_mm = t.positive("shaft_radius_mm", tip.shaft_radius_mm);
  if (t.require("shaft_length_mm")) tip.shaft_length_mm = t.positive("shaft_length_mm", tip.shaft_length_mm);
  if (t.has("direction")) {
    const Vec3 d = t.vec3("direction", tip.direction);
    if (d.norm() < 1e-9) t.problem("direction", "must not be zero");
    else tip.direction = d.normalized();
  }
  tip.head_radius_mm = t.positive("head_radius_mm", tip.head_radius_mm);
  t.finish();
  if (const std::string why = tip_problem(tip); !why.empty() && t.problem_count() == problems_before) {
    const std::size_t colon = why.find(':');  // "field: why"
    t.problem(why.substr(0, colon), why.substr(colon + 2));
  }
  return tip;
}

}  // namespace

const StylusTip* MachineDescription::find_tip(const std::string& id) const {
  for (const StylusTip& t : tips)
    if (t.id == id) return &t;
  return nullptr;
}

const StylusTip& MachineDescription::tip() const {
  if (const StylusTip* t = find_tip(active_tip)) return *t;
  throw std::invalid_argument("machine description: active tip \"" + active_tip + "\" is not among the tips");
}

std::string tip_problem(const StylusTip& tip) {
  if (tip.shaft_radius_mm > tip.ball_radius_mm) return "shaft_radius_mm: is wider than the ball: the shaft would touch first";
  if (tip.shaft_length_mm <= tip.ball_radius_mm) return "shaft_length_mm: does not reach past the ball";
  return {};
}

MachineDescription machine_from_json(const nlohmann::json& j, const std::string& source) {
  JsonFields f(j);
  MachineDescription m;
  if (!f.expect_object()) f.throw_if_problems(source);
  m.name = f.text("name", "");
  f.text("description", "");  // for the reader of the file
  if (f.require("travel_box", "{\"min\", \"max\"}")) {
    JsonFields box = f.object("travel_box");
    if (box.require("min")) m.travel_box.min = box.vec3("min", m.travel_box.min);
    if (box.require("max")) m.travel_box.max = box.vec3("max", m.travel_box.max);
    box.finish();
    if (box.ok() && !(m.travel_box.min.array() < m.travel_box.max.array()).all())
      box.problem("min must be below max on every axis");
  }
  if (f.require("max_speed_mm_s")) m.max_speed_mm_s = f.positive("max_speed_mm_s", m.max_speed_mm_s);
  if (f.require("max_accel_mm_s2")) m.max_accel_mm_s2 = f.positive("max_accel_mm_s2", m.max_accel_mm_s2);
  m.probe_speed_mm_s = f.positive("probe_speed_mm_s", m.probe_speed_mm_s);
  if (m.probe_speed_mm_s > m.max_speed_mm_s) f.problem("probe_speed_mm_s", "exceeds max_speed_mm_s");
  if (f.require("clearance_z")) {
    m.clearance_z = f.number("clearance_z", m.clearance_z, -inf, inf);
    if (m.travel_box.min.z() < m.travel_box.max.z() &&
        (m.clearance_z < m.travel_box.min.z() || m.clearance_z > m.travel_box.max.z()))
      f.problem("clearance_z", "lies outside the travel box");
  }
  if (f.require("tips", "[{\"id\", \"ball_radius_mm\", ...}]")) {
    std::vector<JsonFields> tips = f.objects("tips");
    if (tips.empty() && f.value()["tips"].is_array()) f.problem("tips", "must hold at least one tip");
    for (JsonFields& t : tips) {
      if (!t.value().is_object()) continue;
      m.tips.push_back(read_tip(t));
      for (std::size_t k = 0; k + 1 < m.tips.size(); ++k)
        if (!m.tips.back().id.empty() && m.tips[k].id == m.tips.back().id)
          t.problem("id", "duplicates tip \"" + m.tips[k].id + "\"");
    }
  }
  if (f.require("active_tip")) {
    m.active_tip = f.text("active_tip", "");
    if (f.value()["active_tip"].is_string() && !m.tips.empty() && !m.find_tip(m.active_tip))
      f.problem("active_tip", "\"" + m.active_tip + "\" is not among the tips");
  }
  m.tool_changer = f.flag("tool_changer", m.tool_changer);
  if (f.has("reference_sphere")) {
    JsonFields sphere = f.object("reference_sphere");
    if (sphere.require("centre")) m.reference_sphere.centre = sphere.vec3("centre", m.reference_sphere.centre);
    if (sphere.require("radius_mm")) m.reference_sphere.radius_mm = sphere.positive("radius_mm", m.reference_sphere.radius_mm);
    sphere.finish();
  }
  f.finish();
  f.throw_if_problems(source);
  return m;
}

MachineDescription read_machine(const std::filesystem::path& file) {
  return machine_from_json(read_json_file(file, "the machine description"), file.string());
}

nlohmann::json to_json(const MachineDescription& m) {
  nlohmann::json tips = nlohmann::json::array();
  for (const StylusTip& t : m.tips)
    tips.push_back({{"id", t.id},
                    {"ball_radius_mm", t.ball_radius_mm},
                    {"offset", vec3_json(t.offset)},
                    {"shaft_radius_mm", t.shaft_radius_mm},
                    {"shaft_length_mm", t.shaft_length_mm},
                    {"direction", vec3_json(t.direction)},
                    {"head_radius_mm", t.head_radius_mm}});
  nlohmann::json j = {
      {"travel_box", {{"min", vec3_json(m.travel_box.min)}, {"max", vec3_json(m.travel_box.max)}}},
      {"max_speed_mm_s", m.max_speed_mm_s},
      {"max_accel_mm_s2", m.max_accel_mm_s2},
      {"probe_speed_mm_s", m.probe_speed_mm_s},
      {"clearance_z", m.clearance_z},
      {"tips", tips},
      {"active_tip", m.active_tip},
      {"tool_changer", m.tool_changer},
      {"reference_sphere", {{"centre", vec3_json(m.reference_sphere.centre)}, {"radius_mm", m.reference_sphere.radius_mm}}}};
  if (!m.name.empty()) j["name"] = m.name;
  return j;
}

MachineDescription default_machine() {
  return machine_from_json(nlohmann::json::parse(detail::default_machine_json), "config/machine.json (built in)");
}

}  // namespace cmm::description
