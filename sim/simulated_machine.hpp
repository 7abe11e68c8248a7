// The simulated CMM itself: kinematics, clock, exact contact with the true scene, seeded trigger
// noise and the machine-side faults. The in-process driver and cmm-sim's Modbus and Grbl servers
// are fronts on this one class, so every path drives the same machine.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "hal/description/machine_description.hpp"
#include "hal/machine_status.hpp"
#include "hal/motion.hpp"
#include "sim/scene.hpp"
#include "sim/sim_config.hpp"
#include "sim/trapezoid_profile.hpp"

namespace cmm::sim {

// Builds the scene described by a config: the part (meshed or read), the plate, the sphere, in M.
// Throws geometry::FileError for an unreadable mesh file.
Scene build_scene(const SimConfig& config);

// Positions and touches are ball centres of the active tip as the machine believes them: its
// reference point plus the tip's recorded offset. Contact uses the true tip (true_tips in the
// config), so a tip that was never qualified touches where it really is, not where it is said to be.
//
// Thread rules as hal::Cmm: one motion call at a time; status(), stop() and abort() from any
// thread. With time_scale 0 motion takes no wall time and the clock just advances.
class SimulatedMachine {
 public:
  explicit SimulatedMachine(const SimConfig& config);

  description::MachineDescription info() const;
  hal::MachineStatus status() const;  // lifecycle is the front's business and is left unset

  void home();
  void move(const hal::Move& move);
  hal::TouchResult probe(const hal::ProbeMove& move);
  // A front (a driver, a server) calls this when it accepts a command from its link, before it runs
  // it: a stop() from then on stops that command, even one that has not begun to move yet.
  void accept_command();
  void stop();
  void abort();
  void reset();
  void select_tip(const std::string& tip_id);
  void record_qualification(const std::string& tip_id, const description::TipQualification& q);

  // Truth, which no driver can see: the scene, and where the active tip's ball would first touch it
  // on a search (its reported-frame centre, noise-free).
  const Scene& scene() const { return scene_; }
  const SimConfig& config() const { return config_; }
  std::optional<Vec3> true_contact(const hal::ProbeMove& move) const;
  double true_ball_radius(const std::string& tip_id) const;
  Vec3 true_offset(const std::string& tip_id) const;

 private:
  struct Tip {
    description::StylusTip info;  // nominal or recorded
    double true_radius = 0;
    Vec3 true_offset = Vec3::Zero();
  };
  struct Outcome {
    double travel = 0;     // mm covered
    bool triggered = false;
    bool spurious = false;
  };

  const Tip& active() const;
  std::size_t tip_index(const std::string& id) const;
  Vec3 reported(const Vec3& ref) const { return ref + active().info.offset; }
  void check_can_move(bool need_homed) const;
  void check_in_box(const Vec3& ball, const char* what) const;
  [[noreturn]] void fail(hal::FaultKind kind, const std::string& message);
  // Runs one straight motion of the reference point; stops early on a trigger, a stop/abort
  // request or the e-stop input. Throws the fault for stop, abort and e-stop.
  Outcome run(std::unique_lock<std::mutex>& lock, const Vec3& to_ref, double speed);
  void begin_command();
  double gaussian();

  SimConfig config_;
  Scene scene_;
  std::unique_ptr<SceneContact> contact_;
  std::vector<Tip> tips_;
  std::size_t active_ = 0;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  Vec3 ref_ = Vec3::Zero();  // the reference point, M
  double clock_s_ = 0;
  bool homed_ = false, estop_ = false, aborted_ = false, estop_fired_ = false;
  bool busy_ = false;  // a motion call is running
  bool stop_request_ = false, abort_request_ = false;
  bool accepted_ = false;  // accept_command() was called and its command has not ended
  std::optional<hal::FaultKind> fault_;
  std::string fault_message_;
  int commands_ = 0;
  bool spurious_pending_ = false;
  std::mt19937_64 rng_;

  // The segment in progress, for status() while it runs in wall time.
  bool moving_ = false;
  Vec3 seg_from_ = Vec3::Zero(), seg_dir_ = Vec3::Zero();
  TrapezoidProfile seg_profile_;
  std::chrono::steady_clock::time_point seg_wall_start_;
};

}  // namespace cmm::sim
