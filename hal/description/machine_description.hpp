// The machine description (machine.json; DESIGN.md): one schema for cmm-plan --machine, the
// simulator, a driver's info() and the plans cmmd makes: travel box, motion limits, clearance plane,
// the stylus tips with their qualification, and the reference sphere they are qualified on.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace cmm::description {

using Vec3 = Eigen::Vector3d;

// Reachable positions of the active tip's ball centre, M, mm.
struct TravelBox {
  Vec3 min = Vec3::Zero(), max = Vec3::Zero();
  bool contains(const Vec3& p, double tolerance_mm = 1e-9) const {
    return (p.array() >= min.array() - tolerance_mm).all() && (p.array() <= max.array() + tolerance_mm).all();
  }
};

// What qualification on the reference sphere measured (hal/qualification.hpp): the effective ball
// radius (the nominal less the probe's pre-travel, which is what a touch sees) and the ball centre's
// offset from the machine's reference point.
struct TipQualification {
  double ball_radius_mm = 0;
  Vec3 offset = Vec3::Zero();
  double residual_rms_mm = 0;  // of the sphere fit
  int touches = 0;
  std::string time_utc;  // ISO 8601, when it was measured
};

struct StylusTip {
  std::string id;
  double ball_radius_mm = 1;   // nominal, or the qualified value once there is one
  Vec3 offset = Vec3::Zero();  // ball centre relative to the probe's reference point, M axes
  double shaft_radius_mm = 0.5;
  double shaft_length_mm = 20;      // ball centre to the probe head
  Vec3 direction = -Vec3::UnitZ();  // unit, from the head toward the ball
  double head_radius_mm = 7;        // the probe body, modelled as a sphere at the shaft's top end
  std::optional<TipQualification> qualification;  // what a machine reports; never in machine.json
};

struct ReferenceSphere {
  Vec3 centre = Vec3::Zero();  // M, mm
  double radius_mm = 12.5;
};

struct MachineDescription {
  std::string name;                // what the machine is ("Modbus machine at 10.0.0.5:502")
  TravelBox travel_box;
  double max_speed_mm_s = 100;     // travel moves, along the path
  double max_accel_mm_s2 = 500;
  double probe_speed_mm_s = 5;     // while searching for a contact
  double clearance_z = 0;          // every travel between touches runs at this height, M
  std::vector<StylusTip> tips;
  std::string active_tip;
  // Whether select_tip changes the stylus by itself (an automatic tool changer), or only tells the
  // controller which stylus the operator has fitted by hand (a job then pauses for the change).
  bool tool_changer = true;
  ReferenceSphere reference_sphere;

  const StylusTip* find_tip(const std::string& id) const;  // null when there is none
  const StylusTip& tip() const;  // the active one; std::invalid_argument when it is not among the tips
};

// What makes a tip unusable, as "field: why" ("" when it is fine): a shaft wider than the ball, or
// one that does not reach past it.
std::string tip_problem(const StylusTip& tip);

// Parses and checks a description; FieldError names the source and every bad field by its pointer.
MachineDescription machine_from_json(const nlohmann::json& j, const std::string& source = "<json>");
MachineDescription read_machine(const std::filesystem::path& file);
// The machine.json fields (a tip's qualification is the machine's state, not its description).
nlohmann::json to_json(const MachineDescription& machine);

// config/machine.json, compiled in: cmm-plan's description without --machine, the simulator's and a
// Grbl machine's without one of their own.
MachineDescription default_machine();

}  // namespace cmm::description
