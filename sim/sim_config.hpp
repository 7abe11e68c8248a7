// The simulator's JSON config block (driver "sim" in cmmd.json, and cmm-sim's --config): the
// machine description, the true part and plate and where they stand, the trigger noise, the clock
// and the faults to inject. Every key has a default, so {} is a working machine.
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <string>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "hal/description/json_fields.hpp"
#include "hal/description/machine_description.hpp"
#include "hal/description/plate.hpp"
#include "geometry/mesh.hpp"

namespace cmm::sim {

using geometry::Vec3;

// The true part: one of geometry's analytic parts, or a mesh file (scaled to mm).
struct PartSource {
  std::string analytic = "case3_block";  // one of geometry::analytic_part_names()
  double edge_length_mm = 2;
  std::string mesh_file;  // when set, used instead of `analytic`
  double scale = 1;
};

// How a real tip differs from its nominal description: what qualification must find.
struct TrueTip {
  double ball_radius_mm = 0;  // 0: the nominal radius
  Vec3 offset = Vec3::Zero();  // the true offset is nominal + this
};

// Faults injected on purpose. Link faults act on the HAL commands a transport carries (the
// in-process driver emulates them at its API); machine faults act on the simulated machine.
struct FaultInjection {
  int drop_link_after_commands = 0;  // 0: never; otherwise the link dies after this many commands
  double reply_delay_s = 0;          // every reply arrives this late (a driver with a shorter timeout times out)
  int corrupt_reply_at_command = 0;  // the reply to this command (1-based) is garbled
  int spurious_trigger_at_motion = 0;  // the probe triggers at the start of this motion (1-based)
  int spurious_trigger_count = 1;      // ... and of the motions after it, this many in all (a fouled stylus)
  double estop_at_s = -1;            // the e-stop input goes active when the machine clock passes this
};

struct SimConfig {
  description::MachineDescription machine = description::default_machine();
  description::Plate plate = description::default_plate();
  Eigen::Isometry3d T_M_P = Eigen::Isometry3d::Identity();     // where the plate stands in M
  PartSource part;
  Eigen::Isometry3d T_P_Part = Eigen::Isometry3d::Identity();  // where the part stands on the plate
  // Per-axis limits on top of the description's path limits (+∞: the path limits alone).
  Vec3 axis_max_speed_mm_s = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 axis_max_accel_mm_s2 = Vec3::Constant(std::numeric_limits<double>::infinity());
  double trigger_sigma_mm = 0.001;
  std::uint64_t seed = 1;
  double time_scale = 0;  // 0: virtual clock, motion takes no wall time; > 0: wall time = machine time / this
  Vec3 power_on_position = Vec3::Zero();  // the ball centre before homing
  Vec3 home_position = Vec3::Zero();      // where homing ends (ball centre of the active tip)
  double timeout_s = 5;  // the in-process driver's reply timeout, against reply_delay_s
  std::map<std::string, TrueTip> true_tips;
  FaultInjection faults;
};

// Reads the block; relative file names resolve against `base_dir`. A bad block throws
// description::FieldError listing every problem with its JSON Pointer.
SimConfig sim_config_from_json(const nlohmann::json& block, const std::string& base_dir = ".");

// A pose block {"rotation_deg": [rx, ry, rz] (applied x, then y, then z), "translation": [x, y, z]}.
Eigen::Isometry3d read_pose(description::JsonFields block, const Eigen::Isometry3d& fallback);

}  // namespace cmm::sim
