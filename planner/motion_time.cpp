// The trapezoidal move time; the switch between the triangular and the trapezoidal profile is
// where the move just reaches full speed before it must brake.
#include "planner/motion_time.hpp"

#include <cmath>
#include <stdexcept>

namespace cmm::planner {

double trapezoid_time(double distance_mm, double max_speed_mm_s, double max_accel_mm_s2) {
  // Written so that NaN fails every check.
  if (!(distance_mm >= 0) || !std::isfinite(distance_mm))
    throw std::invalid_argument("trapezoid_time: distance must be finite and not negative");
  if (!(max_speed_mm_s > 0) || !std::isfinite(max_speed_mm_s) || !(max_accel_mm_s2 > 0))
    throw std::invalid_argument("trapezoid_time: speed and acceleration limits must be positive");
  const double v = max_speed_mm_s, a = max_accel_mm_s2;
  const double switch_distance = v * v / a;  // accelerating to v and braking from it
  if (distance_mm <= switch_distance) return 2 * std::sqrt(distance_mm / a);
  return distance_mm / v + v / a;
}

}  // namespace cmm::planner
