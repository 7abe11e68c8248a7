// Touches for edge points and bores; see touch_planning.hpp.
#include "planner/touch_planning.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {

constexpr double deg = std::numbers::pi / 180;


Touch make_touch(TouchTarget target, const Vec3& surface_point, const Vec3& direction, const TouchPlanOptions& o,
                 double pre_travel) {
  Touch t;
  t.target = target;
  t.surface_point = surface_point;
  t.direction = direction.normalized();
  t.nominal_centre = surface_point - o.radius * t.direction;
  t.start = t.nominal_centre - (o.delta + pre_travel) * t.direction;
  t.max_travel_mm = 2 * o.delta + pre_travel + o.overtravel_mm;
  t.min_travel_mm = min_travel_for(t.max_travel_mm);
  t.retract_mm = o.delta + pre_travel;
  return t;
}

struct Candidate {
  double angle;
  Touch touch;
  ClearanceCheck check;
};

// The two-touch pair: both lines through the reference point, at axis ± β if that is clear, else
// the widest clear pair the window allows.
bool plan_two_touch(EdgePlan& plan, const ProbeWindow& window_m, const Vec3& a_m, const StylusClearance& clearance,
                    const TouchPlanOptions& o) {
  const double beta = o.beta_fraction * window_m.half_angle_rad;
  auto candidate = [&](double angle) {
    Candidate c{angle, make_touch(TouchTarget::edge, a_m, direction_in_window(window_m, angle), o, o.pre_travel_mm), {}};
    c.check = clearance.check(c.touch);
    return c;
  };
  auto accept = [&](Candidate& first, Candidate& second) {
    first.touch.face = 0, second.touch.face = 1;
    plan.beta_rad = {first.angle, second.angle};
    plan.touches = {first.touch, second.touch};
    plan.method = EdgeMethod::two_touch;
    return true;
  };
  Candidate plus = candidate(beta), minus = candidate(-beta);
  if (plus.check.ok && minus.check.ok) return accept(plus, minus);
  std::vector<Candidate> clear;
  for (int k = -6; k <= 6; ++k) {
    if (k == 6 || k == -6) {
      Candidate& c = k > 0 ? plus : minus;
      if (c.check.ok) clear.push_back(c);
      continue;
    }
    Candidate c = candidate(beta * k / 6);
    if (c.check.ok) clear.push_back(std::move(c));
  }
  if (clear.size() >= 2) {
    auto [lo, hi] = std::minmax_element(clear.begin(), clear.end(),
                                        [](const Candidate& x, const Candidate& y) { return x.angle < y.angle; });
    if (hi->angle - lo->angle >= o.min_separation_deg * deg) return accept(*hi, *lo);
  }
  const Candidate& failed = plus.check.ok ? minus : plus;
  plan.reason = "two touches in the window are blocked (" + failed.check.reason + ")";
  return false;
}

// Two touches on each side's face, across the edge, along the face's inward normal.
bool plan_faces(EdgePlan& plan, const geometry::EdgePoint& p, const Eigen::Isometry3d& T_M_S,
                const StylusClearance& clearance, const TouchPlanOptions& o) {
  const Vec3 a_m = T_M_S * p.position;
  const Vec3 tangent = T_M_S.linear() * p.tangent;
  const Vec3 normals[2] = {T_M_S.linear() * p.n_up, T_M_S.linear() * *p.n_down};
  // Far enough from the edge that its real position cannot matter; a concave edge also needs the
  // ball's radius, or the ball would meet the other face.
  const double first = o.delta + o.pre_travel_mm + (p.convex ? 0.0 : o.radius);
  std::vector<Touch> touches;
  for (int side = 0; side < 2; ++side) {
    const Vec3& n = normals[side];
    Vec3 along = tangent.cross(n).normalized();  // in the face, perpendicular to the edge
    const double toward_other = along.dot(normals[1 - side]);
    if ((p.convex && toward_other > 0) || (!p.convex && toward_other < 0)) along = -along;
    for (int k = 0; k < 2; ++k) {
      Touch t = make_touch(TouchTarget::face, a_m + (first + k * o.face_step_mm) * along, -n, o, o.pre_travel_mm);
      t.face = 2 * side + k;
      if (const ClearanceCheck check = clearance.check(t); !check.ok) {
        plan.reason += std::string(plan.reason.empty() ? "" : "; ") + "the " + (side == 0 ? "upper" : "lower") +
                       " face is out of reach (" + check.reason + ")";
        return false;
      }
      touches.push_back(t);
    }
  }
  plan.touches = std::move(touches);
  plan.method = EdgeMethod::faces;
  return true;
}

}  // namespace

const char* to_string(EdgeMethod method) {
  switch (method) {
    case EdgeMethod::none: return "none";
    case EdgeMethod::two_touch: return "two_touch";
    case EdgeMethod::faces: return "faces";
  }
  return "?";
}

EdgePlan plan_edge_point(const geometry::EdgePoint& point, const Eigen::Isometry3d& T_M_S,
                         const StylusClearance& clearance, const TouchPlanOptions& options) {
  EdgePlan plan;
  plan.edge_point = point.id;
  if (!point.probeable) {
    plan.reason = point.reason;
    return plan;
  }
  if (!point.n_down) {
    plan.reason = "an open boundary: the scan saw one side only, there is nothing to touch against";
    return plan;
  }
  // Where the point's own position is less sure than the plan's δ allows (a small rim smoothed less), or
  // the mesh's crease is itself off the true edge (a coarse fan's chord), the point's δ grows by it.
  TouchPlanOptions o = options;
  o.delta = geometry::delta_at(point, options.delta);
  plan.delta_mm = o.delta;
  const WindowResult window = probe_window(point, o.radius, o.delta, o.window);
  if (window.usable) {
    plan.window = window.window;
    ProbeWindow in_m = window.window;
    in_m.axis = T_M_S.linear() * in_m.axis;
    in_m.bisector = T_M_S.linear() * in_m.bisector;
    in_m.plane_normal = T_M_S.linear() * in_m.plane_normal;
    if (plan_two_touch(plan, in_m, T_M_S * point.position, clearance, o)) return plan;
  } else {
    plan.reason = window.reason;
    if (3 * point.position_sigma_mm > options.delta)
      plan.reason += " (delta here " + fixed(o.delta, 3) + " mm: 3 standard errors of this point's own position, " +
                     "whose crease the vertex noise moves more than the plan's delta allows)";
    else if (point.mesh_deviation_mm > 0.25 * options.delta)
      plan.reason += " (delta here " + fixed(o.delta, 3) + " mm, of which " + fixed(point.mesh_deviation_mm, 3) +
                     " mm is the mesh's own distance from the edge: its crease is a chord of a coarse tessellation)";
  }
  const std::string why_not_two = plan.reason;
  if (plan_faces(plan, point, T_M_S, clearance, o)) {
    plan.reason = why_not_two + ": measured on its two faces";
    return plan;
  }
  return plan;
}

BorePlan plan_bore(const geometry::Hole& hole, const Eigen::Isometry3d& T_M_S, const StylusClearance& clearance,
                   const TouchPlanOptions& o) {
  BorePlan plan;
  plan.hole = hole.id;
  if (!hole.depth) {
    plan.reason = "the hole's wall is not in the mesh (an open rim): its rim is measured, not its bore";
    return plan;
  }
  if (o.radius > o.bore_ball_fraction * hole.radius) {
    plan.reason = "the ball (r " + fixed(o.radius, 3) + " mm) is too large for a bore of radius " + fixed(hole.radius, 3) +
                  " mm (needs r <= " + fixed(o.bore_ball_fraction, 2) + " x radius)";
    return plan;
  }
  // Touch halfway down, so the ball stays clear of both rims by at least its radius and δ.
  const double keep = o.radius + o.delta + o.overtravel_mm + 0.2;
  if (*hole.depth < 2 * keep) {
    plan.reason = "the wall is only " + fixed(*hole.depth, 3) + " mm deep: a ball of radius " + fixed(o.radius, 3) +
                  " mm cannot touch it clear of its rims";
    return plan;
  }
  plan.depth_mm = *hole.depth / 2;
  const Vec3 axis = (T_M_S.linear() * hole.axis).normalized();
  const Vec3 centre = T_M_S * hole.centre - plan.depth_mm * axis;
  const Vec3 u = axis.unitOrthogonal(), v = axis.cross(u);
  // Start halfway between the axis and the wall: the ball descends well clear of a noisy wall.
  const double pre_travel = std::max(o.pre_travel_mm, (hole.radius - o.radius) / 2 - o.delta);
  for (int k = 0; k < o.bore_touches; ++k) {
    const double angle = 2 * std::numbers::pi * k / o.bore_touches;
    const Vec3 radial = std::cos(angle) * u + std::sin(angle) * v;
    Touch t = make_touch(TouchTarget::bore, centre + hole.radius * radial, radial, o, pre_travel);
    t.hole = hole.id, t.face = k;
    if (const ClearanceCheck check = clearance.check(t); !check.ok) {
      plan.touches.clear();
      plan.reason = "bore touch " + std::to_string(k) + " is out of reach (" + check.reason + ")";
      return plan;
    }
    plan.touches.push_back(t);
  }
  plan.planned = true;
  return plan;
}

}  // namespace cmm::planner
