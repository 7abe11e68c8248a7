// Which touches measure each feature: two touches in a convex edge point's window, touches on the
// faces beside an edge without one, six on a bore's wall; each checked for safety in M.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/edge_point.hpp"
#include "geometry/hole.hpp"
#include "planner/probe_window.hpp"
#include "planner/stylus_clearance.hpp"

namespace cmm::planner {

struct TouchPlanOptions {
  double radius = 1;   // ball radius, mm
  double delta = 0.2;  // bound on a reference point's error in M, mm
  // The search runs from (δ + pre-travel) before the nominal contact to (δ + overtravel) past it:
  // enough run-up to reach probing speed and to keep the descent off the surface, and little
  // overtravel, since the shaft follows the ball toward the part.
  double pre_travel_mm = 1.0;
  double overtravel_mm = 0.1;
  double beta_fraction = 0.9;     // two touches at axis ± β, β = this × the usable half-angle
  double min_separation_deg = 10; // narrower pairs leave the intersection too uncertain
  double face_step_mm = 1.5;      // between the two touches on one face, across the edge
  double bore_ball_fraction = 0.8;  // a bore is probed when r ≤ this × its radius
  int bore_touches = 6;
  WindowOptions window;
};

enum class EdgeMethod { none, two_touch, faces };
const char* to_string(EdgeMethod method);

struct EdgePlan {
  int edge_point = -1;
  EdgeMethod method = EdgeMethod::none;
  std::optional<ProbeWindow> window;  // in S, when the point has a usable one
  std::array<double, 2> beta_rad = {0, 0};  // angles of the two touches from the axis (two_touch)
  std::vector<Touch> touches;         // ids are assigned later, in M
  std::string reason;  // why not measurable, or why faces instead of two touches
  double delta_mm = 0;  // the bound on the reference point's error its window and touches were made for
  std::string tip;         // the tip it is planned for (empty: the active one)
  double radius_mm = 0;    // that tip's ball radius as planned (0: compensation's default)
};

// Plans one edge point given in S; touches are placed in M through T_M_S.
EdgePlan plan_edge_point(const geometry::EdgePoint& point, const Eigen::Isometry3d& T_M_S,
                         const StylusClearance& clearance, const TouchPlanOptions& options);

struct BorePlan {
  int hole = -1;
  bool planned = false;
  double depth_mm = 0;  // below the entry rim, along −axis, where the wall is touched
  std::vector<Touch> touches;
  std::string reason;
  std::string tip;         // as EdgePlan's
  double radius_mm = 0;
};

BorePlan plan_bore(const geometry::Hole& hole, const Eigen::Isometry3d& T_M_S, const StylusClearance& clearance,
                   const TouchPlanOptions& options);

}  // namespace cmm::planner
