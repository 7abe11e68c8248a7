// The machine description (machine.json; one schema for cmm-plan --machine, the simulator and the
// HAL's MachineInfo): travel box, motion limits, clearance plane and the qualified stylus tips.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "geometry/mesh.hpp"

namespace cmm::planner {

using geometry::Vec3;

struct AxisBox {
  Vec3 min = Vec3::Zero(), max = Vec3::Zero();
  bool contains(const Vec3& p, double tolerance = 1e-9) const {
    return (p.array() >= min.array() - tolerance).all() && (p.array() <= max.array() + tolerance).all();
  }
};

struct StylusTip {
  std::string id;
  double ball_radius_mm = 1;   // qualified on the reference sphere
  Vec3 offset = Vec3::Zero();  // ball centre relative to the probe's reference point, M axes
  double shaft_radius_mm = 0.5;
  double shaft_length_mm = 20;  // ball centre to the probe head
  Vec3 direction = -Vec3::UnitZ();  // unit, from the head toward the ball
  double head_radius_mm = 7;   // the probe body, modelled as a sphere at the shaft's top end
};

struct ReferenceSphere {
  Vec3 centre = Vec3::Zero();
  double radius_mm = 12.5;
};

struct MachineDescription {
  AxisBox travel_box;              // reachable ball-centre positions, M
  double max_speed_mm_s = 100;     // travel moves
  double max_accel_mm_s2 = 500;
  double probe_speed_mm_s = 5;     // while searching for a contact
  double clearance_z = 0;          // every travel between touches runs at this height, M
  std::vector<StylusTip> tips;
  std::string active_tip;
  ReferenceSphere reference_sphere;

  const StylusTip& tip() const;  // the active one
};

// What makes a tip unusable, as "field: why" ("" when it is fine): a shaft wider than the ball, or
// one that does not reach past it.
std::string tip_problem(const StylusTip& tip);

// Parses and checks a description; errors name the file (or "<json>") and the field.
MachineDescription machine_from_json(const nlohmann::json& j, const std::string& source = "<json>");
MachineDescription read_machine(const std::filesystem::path& file);
nlohmann::json to_json(const MachineDescription& machine);

// The description cmm-plan uses without --machine: config/machine.json, compiled in so the tool
// works from any directory.
MachineDescription default_machine();

}  // namespace cmm::planner
