// Probe windows and their 2-D validation; see probe_window.hpp for the derivation.
#include "planner/probe_window.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {

constexpr double deg = std::numbers::pi / 180;


}  // namespace

double feasible_half_angle(double interior_angle_rad, double radius, double delta) {
  if (!(radius > 0) || !(delta >= 0) || delta >= radius) return -std::numbers::pi;
  return std::acos(delta / radius) - interior_angle_rad / 2;
}

WedgeTouch validate_touch(double interior_angle_rad, double radius, const Eigen::Vector2d& reference,
                          const Eigen::Vector2d& approach) {
  const double half = interior_angle_rad / 2;
  // Face rays leave the apex downward on either side of the −y bisector; normals point out.
  const Eigen::Vector2d faces[2] = {{-std::sin(half), -std::cos(half)}, {std::sin(half), -std::cos(half)}};
  const Eigen::Vector2d normals[2] = {{-std::cos(half), std::sin(half)}, {std::cos(half), std::sin(half)}};
  WedgeTouch result;
  result.touches_apex = true;
  for (int i = 0; i < 2; ++i) {
    const double closing = approach.dot(normals[i]);
    if (closing >= 0) {  // moving along or away from this face's line: it is never met from outside
      result.face_hit_along[i] = -std::numeric_limits<double>::infinity();
      continue;
    }
    // Eq. 5.12–5.13: the ball's centre reaches the line's offset by r at u; P is the foot there.
    const double u = (radius - reference.dot(normals[i])) / closing;
    const Eigen::Vector2d p = reference + u * approach - radius * normals[i];
    result.face_hit_along[i] = p.dot(faces[i]);
    if (result.face_hit_along[i] > 0) result.touches_apex = false;
  }
  return result;
}

int count_false_edge_points(double interior_angle_rad, double radius, double delta, double approach_angle_rad,
                            int samples) {
  const Eigen::Vector2d approach(std::sin(approach_angle_rad), -std::cos(approach_angle_rad));
  int false_points = 0;
  for (double t : {delta, delta / 2, 0.0}) {
    for (int k = 0; k < samples; ++k) {
      const double theta = 2 * std::numbers::pi * k / samples;
      const Eigen::Vector2d reference(t * std::cos(theta), t * std::sin(theta));
      false_points += !validate_touch(interior_angle_rad, radius, reference, approach).touches_apex;
    }
  }
  return false_points;
}

WindowResult probe_window(const geometry::EdgePoint& point, double radius, double delta, const WindowOptions& options) {
  WindowResult result;
  if (!point.n_down) {
    result.reason = "an open boundary has one side only: no window";
    return result;
  }
  if (!point.convex) {
    result.reason = "concave edge: a ball cannot reach its apex";
    return result;
  }
  const Vec3& up = point.n_up;
  const Vec3& down = *point.n_down;
  const Vec3 sum = up + down;
  const Vec3 cross = up.cross(down);
  if (sum.norm() < 1e-6 || cross.norm() < 1e-6) {
    result.reason = "the two side normals are parallel: no edge to window";
    return result;
  }
  if (!(point.n_up_uncertainty_rad >= 0) || !(point.n_down_uncertainty_rad >= 0) ||
      !std::isfinite(point.n_up_uncertainty_rad + point.n_down_uncertainty_rad)) {
    result.reason = "the side normals' uncertainty is not a finite, non-negative angle";
    return result;
  }
  if (!(delta < radius)) {
    result.reason = "delta " + fixed(delta, 3) + " mm is not below the ball radius " + fixed(radius, 3) + " mm";
    return result;
  }
  const double alpha = std::numbers::pi - std::acos(std::clamp(up.dot(down), -1.0, 1.0));
  ProbeWindow& w = result.window;
  w.bisector = -sum.normalized();
  w.axis = w.bisector;
  w.plane_normal = cross.normalized();
  w.exact_half_angle_rad = feasible_half_angle(alpha, radius, delta);
  // Each edge of the fan is set by one side's normal alone (the ball's entry angle against that
  // face), so each edge gives up its own side's error bound and the window turns away from the
  // less certain side. Only a normal's turn about the tangent moves the fan, and that is the error
  // the edge point's uncertainty states.
  const double bias = options.normal_bias_deg * deg;
  w.margin_up_rad = options.normal_sigmas * point.n_up_uncertainty_rad + bias;
  w.margin_down_rad = options.normal_sigmas * point.n_down_uncertainty_rad + bias;
  w.margin_rad = (w.margin_up_rad + w.margin_down_rad) / 2;
  w.half_angle_rad = w.exact_half_angle_rad - w.margin_rad;
  w.axis = direction_in_window(w, (w.margin_down_rad - w.margin_up_rad) / 2);
  if (w.exact_half_angle_rad <= 0) {
    result.reason = "no window: acos(delta/r) - alpha/2 = " + fixed(w.exact_half_angle_rad / deg) + " deg (alpha " +
                    fixed(alpha / deg) + " deg, r " + fixed(radius, 3) + " mm, delta " + fixed(delta, 3) + " mm)";
  } else if (!(w.half_angle_rad >= options.min_half_angle_deg * deg)) {
    result.reason = "window too narrow: phi " + fixed(w.exact_half_angle_rad / deg) + " deg less a normal margin of " +
                    fixed(w.margin_rad / deg) + " deg leaves " + fixed(w.half_angle_rad / deg) + " deg (minimum " +
                    fixed(options.min_half_angle_deg) + ")";
  } else {
    result.usable = true;
  }
  return result;
}

Vec3 direction_in_window(const ProbeWindow& window, double angle_rad) {
  // plane_normal × axis points toward n_up's side, since axis ∝ −(n_up + n_down).
  const Vec3 toward_up = window.plane_normal.cross(window.axis).normalized();
  return (std::cos(angle_rad) * window.axis - std::sin(angle_rad) * toward_up).normalized();
}

}  // namespace cmm::planner
