// The simulated machine's motion along one straight segment: a rest-to-rest trapezoidal speed
// profile under path limits derived from per-axis speed and acceleration limits.
#pragma once

#include <Eigen/Core>

namespace cmm::sim {

struct TrapezoidProfile {
  double distance_mm = 0;
  double speed_mm_s = 0;    // cruise speed reached (below the limit on short moves)
  double accel_mm_s2 = 0;

  double accel_time() const { return accel_mm_s2 > 0 ? speed_mm_s / accel_mm_s2 : 0; }
  double duration() const;
  double position_at(double t) const;  // mm along the segment, clamped to [0, distance]
  double speed_at(double t) const;
  double time_at(double s) const;      // first time the position reaches s (inverse of position_at)
  // Where a controlled stop that starts braking at time t comes to rest, and when.
  double stop_position(double t) const;
  double stop_time(double t) const;
};

// The profile of a `distance_mm` move at up to `speed_mm_s` with acceleration `accel_mm_s2`
// (both > 0). Throws std::invalid_argument for a negative or non-finite distance or bad limits.
TrapezoidProfile make_profile(double distance_mm, double speed_mm_s, double accel_mm_s2);

// Path limits along unit direction u when each axis i may go at most axis_limit[i]: the path may
// not exceed path_limit nor axis_limit[i] / |u_i| on any axis.
double path_limit(const Eigen::Vector3d& u, double path_limit, const Eigen::Vector3d& axis_limit);

}  // namespace cmm::sim
