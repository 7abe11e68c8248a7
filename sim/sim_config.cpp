// Parsing the simulator's config block: defaults for everything, every problem reported by path.
#include "sim/sim_config.hpp"

#include <filesystem>
#include <numbers>

#include "geometry/analytic_parts.hpp"

namespace cmm::sim {

Eigen::Isometry3d read_pose(description::JsonFields block, const Eigen::Isometry3d& fallback) {
  if (!block.has("rotation_deg") && !block.has("translation")) {
    block.finish();
    return fallback;
  }
  const Vec3 r = block.vec3("rotation_deg", Vec3::Zero()) * std::numbers::pi / 180;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
                Eigen::AngleAxisd(r.x(), Vec3::UnitX()))
                   .toRotationMatrix();
  T.translation() = block.vec3("translation", Vec3::Zero());
  block.finish();
  return T;
}

SimConfig sim_config_from_json(const nlohmann::json& j, const std::string& base_dir) {
  description::JsonFields block(j);
  block.expect_object();
  SimConfig c;
  block.text("driver", "sim", {"sim"});
  c.machine = description::described(block, "machine", c.machine, base_dir, description::machine_from_json,
                                     description::read_machine);
  c.plate = description::described(block, "plate", c.plate, base_dir, description::plate_from_json,
                                   description::read_plate);

  // By default the plate stands near the middle of the default travel box and the part near the
  // plate's middle, both square to the axes.
  Eigen::Isometry3d plate_pose = Eigen::Isometry3d::Identity();
  plate_pose.translation() = Vec3(200, 300, 0);
  c.T_M_P = read_pose(block.object("plate_pose"), plate_pose);
  Eigen::Isometry3d part_pose = Eigen::Isometry3d::Identity();
  part_pose.translation() = Vec3(50, 25, 0);
  c.T_P_Part = read_pose(block.object("part_pose"), part_pose);

  {
    description::JsonFields part = block.object("part");
    const auto& names = geometry::analytic_part_names();
    c.part.analytic = part.text("analytic", c.part.analytic, std::set<std::string>(names.begin(), names.end()));
    c.part.edge_length_mm = part.number("edge_length_mm", c.part.edge_length_mm, 0.05, 50);
    c.part.mesh_file = part.text("mesh", "");
    if (!c.part.mesh_file.empty()) c.part.mesh_file = description::resolve_config_path(c.part.mesh_file, base_dir).string();
    c.part.scale = part.number("scale", 1, 1e-6, 1e6);
    part.finish();
  }

  c.axis_max_speed_mm_s = block.vec3("axis_max_speed_mm_s", c.axis_max_speed_mm_s);
  c.axis_max_accel_mm_s2 = block.vec3("axis_max_accel_mm_s2", c.axis_max_accel_mm_s2);
  if (!(c.axis_max_speed_mm_s.array() > 0).all() || !(c.axis_max_accel_mm_s2.array() > 0).all())
    block.problem("axis_max_speed_mm_s", "per-axis limits must be > 0");
  c.trigger_sigma_mm = block.number("trigger_sigma_mm", c.trigger_sigma_mm, 0, 1);
  c.seed = static_cast<std::uint64_t>(block.number("seed", 1, 0, 9007199254740992.0));
  c.time_scale = block.number("time_scale", 0, 0, 1e9);
  c.timeout_s = block.number("timeout_s", c.timeout_s, 1e-3, 3600);
  const auto& box = c.machine.travel_box;
  c.home_position = block.vec3("home_position", box.max);
  c.power_on_position = block.vec3("power_on_position", Vec3(0.5 * (box.min.x() + box.max.x()),
                                                               0.5 * (box.min.y() + box.max.y()), box.max.z() - 50));
  if (!box.contains(c.home_position)) block.problem("home_position", "must lie inside the machine's travel box");

  {
    description::JsonFields tips = block.object("true_tips");
    if (tips.value().is_object()) {
      for (const auto& [id, value] : tips.value().items()) {
        description::JsonFields tip = tips.object(id);
        if (!c.machine.find_tip(id)) tips.problem(id, "no tip with this id in the machine description");
        TrueTip truth;
        truth.ball_radius_mm = tip.number("ball_radius_mm", 0, 0.01, 50);
        truth.offset = tip.vec3("offset_error", Vec3::Zero());
        tip.finish();
        c.true_tips[id] = truth;
      }
    }
  }

  {
    description::JsonFields f = block.object("faults");
    c.faults.drop_link_after_commands = f.integer("drop_link_after_commands", 0, 0, 1 << 30);
    c.faults.reply_delay_s = f.number("reply_delay_s", 0, 0, 3600);
    c.faults.corrupt_reply_at_command = f.integer("corrupt_reply_at_command", 0, 0, 1 << 30);
    c.faults.spurious_trigger_at_motion = f.integer("spurious_trigger_at_motion", 0, 0, 1 << 30);
    c.faults.spurious_trigger_count = f.integer("spurious_trigger_count", 1, 1, 1 << 30);
    c.faults.estop_at_s = f.number("estop_at_s", -1, -1, 1e9);
    f.finish();
  }
  block.finish();
  block.throw_if_problems("simulator config");
  return c;
}

}  // namespace cmm::sim
