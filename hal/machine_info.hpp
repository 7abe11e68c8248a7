// What a machine says about itself (MachineInfo) and its moment-to-moment state (MachineStatus):
// the HAL's view of the machine description of DESIGN.md, plus tip qualification and lifecycle.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "hal/fault.hpp"
#include "hal/motion.hpp"

namespace cmm::hal {

struct TravelBox {
  Vec3 min = Vec3::Zero(), max = Vec3::Zero();
  bool contains(const Vec3& p, double tolerance_mm = 1e-9) const {
    return (p.array() >= min.array() - tolerance_mm).all() && (p.array() <= max.array() + tolerance_mm).all();
  }
};

// The result of qualify(): the tip's effective ball radius (the nominal radius less the probe's
// pre-travel, which is what a touch sees) and the ball centre's offset from the machine's reference
// point, from a sphere fit on the reference sphere.
struct TipQualification {
  double ball_radius_mm = 0;
  Vec3 offset = Vec3::Zero();
  double residual_rms_mm = 0;  // of the sphere fit
  int touches = 0;
  std::string time_utc;  // ISO 8601, when it was measured
};

struct TipInfo {
  std::string id;
  double ball_radius_mm = 1;   // nominal, or the qualified value once there is one
  Vec3 offset = Vec3::Zero();  // ball centre from the reference point, M axes
  std::optional<TipQualification> qualification;
};

struct ReferenceSphereInfo {
  Vec3 centre = Vec3::Zero();  // M, mm
  double radius_mm = 0;
};

struct MachineInfo {
  std::string driver;  // "sim", "modbus", "grbl"
  std::string description;
  TravelBox travel_box;         // reachable ball centres of the active tip, M
  double max_speed_mm_s = 0;    // along the path
  double max_accel_mm_s2 = 0;
  double probe_speed_mm_s = 0;  // the default search speed
  std::vector<TipInfo> tips;
  std::string active_tip;
  ReferenceSphereInfo reference_sphere;
};

// configure → connect → enable; disable and faults drop back to connected; disconnect to configured.
enum class Lifecycle { unconfigured, configured, connected, enabled };
const char* to_string(Lifecycle state);
// Throws StateError ("move: the Modbus machine is connected, needs enabled") when `now` is short
// of `needed`: every driver's check before a call.
void require_lifecycle(Lifecycle now, Lifecycle needed, const char* what, const char* machine);

// What the machine is doing now. `fault` holds the last fault until the next motion succeeds or
// reset() clears a latched one (abort, e-stop).
struct MachineStatus {
  Lifecycle lifecycle = Lifecycle::unconfigured;
  bool homed = false;
  bool moving = false;
  bool estop = false;    // the machine's e-stop input is active
  bool aborted = false;  // abort() latched; reset() clears it
  Vec3 position = Vec3::Zero();  // ball centre of the active tip, M (meaningful once homed)
  std::optional<FaultKind> fault;
  std::string fault_message;
  std::string tip_id;
  double t_s = 0;  // machine clock
};

}  // namespace cmm::hal
