// Probe windows (thesis §5.2, DESIGN.md): for a convex edge point, the fan of approach directions
// from which a ball of radius r touches the true edge although the reference point is up to δ off.
#pragma once

#include <string>

#include "geometry/edge_point.hpp"

namespace cmm::planner {

using geometry::Vec3;

// The exact 2-D result. A ball moving along a line at perpendicular offset e from the apex first
// meets the circle of radius r about the apex at the angle asin(e/r) off its direction; it touches
// the apex, not a face, while that point lies inside the apex's normal cone, whose half-angle is
// π/2 − α/2. With |e| ≤ δ for every reference point within δ, the half-angle about the bisector is
// φ = π/2 − α/2 − asin(δ/r) = acos(δ/r) − α/2 (thesis eq. 5.7). Negative when there is no window.
double feasible_half_angle(double interior_angle_rad, double radius, double delta);

// Thesis §5.2.4 (eq. 5.8–5.13) in closed form, in the wedge's cross-section: apex at the origin,
// the material below, its bisector along −y. A ball of `radius` moves along `approach` (unit,
// into the material) through the reference point `reference` (relative to the true apex). Each
// face is an infinite line first; the ball meets it at P; when P lies on the real face ray rather
// than beyond the apex, the ball touches that face before the edge: a false edge point.
struct WedgeTouch {
  bool touches_apex = false;
  double face_hit_along[2] = {0, 0};  // signed position of P on each face ray (> 0: on the face)
};
WedgeTouch validate_touch(double interior_angle_rad, double radius, const Eigen::Vector2d& reference,
                          const Eigen::Vector2d& approach);

// Counts the false edge points of one approach over reference points on the circle of radius δ
// around the apex (and inside it) at `samples` angles: the thesis's validation algorithm.
int count_false_edge_points(double interior_angle_rad, double radius, double delta, double approach_angle_rad,
                            int samples = 720);

struct WindowOptions {
  // A side normal's turn about the edge is bounded by this many of its standard errors plus the
  // bias allowance below; each edge of the fan gives up its own side's bound. 3.5: one-sided, one
  // normal in 4,000 beyond it, were the stated errors exact (tests find them within ±30 %).
  double normal_sigmas = 3.5;
  double normal_bias_deg = 0.1;
  // Windows narrower than this leave the two-touch intersection too uncertain (≈ 1/sin β).
  double min_half_angle_deg = 5.0;
};

// The usable window is [−φ + margin_down, φ − margin_up] about the bisector (positive toward
// n_up's side): its axis is the bisector turned by (margin_down − margin_up)/2.
struct ProbeWindow {
  Vec3 axis = Vec3::Zero();          // unit, into the material: the usable window's centre line
  Vec3 bisector = Vec3::Zero();      // −normalize(n_up + n_down), the exact fan's centre line
  Vec3 plane_normal = Vec3::Zero();  // the cross-section plane's normal, the edge tangent
  double half_angle_rad = 0;         // usable half-angle: φ − (margin_up + margin_down)/2
  double margin_rad = 0;             // (margin_up + margin_down)/2
  double margin_up_rad = 0;          // taken off the fan's edge on n_up's side, set by n_up alone
  double margin_down_rad = 0;
  double exact_half_angle_rad = 0;   // φ from the estimated normals, before the margins
};

struct WindowResult {
  bool usable = false;
  ProbeWindow window;
  std::string reason;  // why not usable
};

// The window of a convex edge point with two measured or inferred side normals.
WindowResult probe_window(const geometry::EdgePoint& point, double radius, double delta, const WindowOptions& options = {});

// A unit direction in the window's plane at `angle` from its axis (positive toward n_up's side).
Vec3 direction_in_window(const ProbeWindow& window, double angle_rad);

}  // namespace cmm::planner
