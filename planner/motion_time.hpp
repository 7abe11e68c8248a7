// Machine time of a straight rest-to-rest move under a speed and acceleration limit; the travel
// metric the move program is ordered and bounded with.
#pragma once

#include <Eigen/Core>

namespace cmm::planner {

// Seconds for a straight move of distance_mm that starts and ends at rest, with a symmetric
// trapezoidal speed profile: accelerate at max_accel_mm_s2 to max_speed_mm_s, cruise, brake at the
// same rate. Moves shorter than v²/a never reach full speed and take the triangular profile
// 2·√(d/a); longer ones take d/v + v/a. Both give 2v/a at the switch distance v²/a.
//
// t(d) is increasing and concave with t(0) = 0, hence subadditive, so t(|a − b|) satisfies the
// triangle inequality and is a metric on points. The tour improvement (shortcuts never cost more)
// and the spanning-tree lower bound in travel_bound.hpp rely on that.
//
// Throws std::invalid_argument when the distance is negative or not finite, or when a limit is
// not positive (an infinite acceleration is allowed: the move then takes d/v).
double trapezoid_time(double distance_mm, double max_speed_mm_s, double max_accel_mm_s2);

// The travel-time metric between two points: trapezoid_time of their distance.
struct TravelCost {
  double max_speed_mm_s = 100;
  double max_accel_mm_s2 = 500;

  double of_distance(double distance_mm) const {
    return trapezoid_time(distance_mm, max_speed_mm_s, max_accel_mm_s2);
  }
  double operator()(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const { return of_distance((a - b).norm()); }
  double operator()(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const { return of_distance((a - b).norm()); }
};

}  // namespace cmm::planner
