// Trapezoidal profile arithmetic: accelerate, cruise, brake, all at one rate.
#include "sim/trapezoid_profile.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace cmm::sim {

TrapezoidProfile make_profile(double distance_mm, double speed_mm_s, double accel_mm_s2) {
  if (!std::isfinite(distance_mm) || distance_mm < 0)
    throw std::invalid_argument("motion profile: distance must be finite and ≥ 0");
  if (!(speed_mm_s > 0) || !(accel_mm_s2 > 0) || !std::isfinite(speed_mm_s))
    throw std::invalid_argument("motion profile: speed and acceleration limits must be > 0");
  TrapezoidProfile p;
  p.distance_mm = distance_mm;
  p.accel_mm_s2 = accel_mm_s2;
  // A move shorter than v²/a never reaches v: it peaks at √(d·a).
  p.speed_mm_s = std::min(speed_mm_s, std::sqrt(distance_mm * accel_mm_s2));
  return p;
}

double TrapezoidProfile::duration() const {
  if (distance_mm == 0 || speed_mm_s == 0) return 0;
  return distance_mm / speed_mm_s + accel_time();
}

double TrapezoidProfile::position_at(double t) const {
  if (speed_mm_s == 0 || t <= 0) return 0;
  const double ta = accel_time(), total = duration();
  if (t >= total) return distance_mm;
  const double ramp = 0.5 * accel_mm_s2 * ta * ta;
  if (t < ta) return 0.5 * accel_mm_s2 * t * t;
  if (t <= total - ta) return ramp + speed_mm_s * (t - ta);
  double left = total - t;
  return std::clamp(distance_mm - 0.5 * accel_mm_s2 * left * left, 0.0, distance_mm);
}

double TrapezoidProfile::speed_at(double t) const {
  const double ta = accel_time(), total = duration();
  if (t <= 0 || t >= total) return 0;
  if (t < ta) return accel_mm_s2 * t;
  if (t <= total - ta) return speed_mm_s;
  return accel_mm_s2 * (total - t);
}

double TrapezoidProfile::time_at(double s) const {
  if (s <= 0 || speed_mm_s == 0) return 0;
  const double ta = accel_time(), total = duration();
  if (s >= distance_mm) return total;
  const double ramp = 0.5 * accel_mm_s2 * ta * ta;
  if (s < ramp) return std::sqrt(2 * s / accel_mm_s2);
  if (s <= distance_mm - ramp) return ta + (s - ramp) / speed_mm_s;
  return total - std::sqrt(2 * (distance_mm - s) / accel_mm_s2);
}

double TrapezoidProfile::stop_position(double t) const {
  double v = speed_at(t);
  return std::min(distance_mm, position_at(t) + v * v / (2 * accel_mm_s2));
}

double TrapezoidProfile::stop_time(double t) const {
  return std::min(duration(), t + speed_at(t) / accel_mm_s2);
}

double path_limit(const Eigen::Vector3d& u, double path_limit, const Eigen::Vector3d& axis_limit) {
  double limit = path_limit;
  for (int i = 0; i < 3; ++i)
    if (std::abs(u[i]) > 1e-12) limit = std::min(limit, axis_limit[i] / std::abs(u[i]));
  return limit;
}

}  // namespace cmm::sim
