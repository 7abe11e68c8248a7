// One planned touch: the probing motion that should meet the part at a nominal point, and what it
// measures. Touches are planned in the machine frame M; ball-centre positions throughout.
#pragma once

#include <algorithm>
#include <string>

#include "geometry/mesh.hpp"

namespace cmm::planner {

using geometry::Vec3;

enum class TouchTarget {
  edge,        // one of the two touches of a convex edge point, both lines through the point
  face,        // a touch on a face next to an edge point (concave edges, points without a window)
  bore,        // a touch on a hole's wall
  plate_face,  // a touch on a base-plate face near a corner, for registration
  fiducial,    // a touch on the plate's asymmetric fiducial
};

const char* to_string(TouchTarget target);

// The minimum travel a plan gives a search of `max_travel_mm`: its first fifth, at most 0.5 mm. Every
// search starts more than that before the earliest contact the real part allows (δ + pre-travel
// before the nominal one), so a trigger there is no touch of the part.
inline double min_travel_for(double max_travel_mm) { return std::min(0.2 * max_travel_mm, 0.5); }

struct Touch {
  int id = 0;  // stable within a plan
  TouchTarget target = TouchTarget::edge;
  int edge_point = -1;  // plan edge point id, for edge and face touches
  int hole = -1;        // hole id, for bore touches
  int corner = -1;      // plate corner index, for plate_face touches
  int face = 0;         // which side / face / wall position of its feature the touch is on
  Vec3 surface_point = Vec3::Zero();  // where the ball should meet the part (the reference point for an edge)
  Vec3 direction = -Vec3::UnitZ();    // unit approach direction, into the material
  Vec3 nominal_centre = Vec3::Zero(); // ball centre at the nominal contact: surface_point − r·direction
  Vec3 start = Vec3::Zero();          // ball centre where the search begins
  double max_travel_mm = 0;           // search length from `start`; ends past the nominal contact
  // A trigger nearer the start than this is no touch (the part is far from where the plan puts it,
  // or the probe fouled): the machine refuses it as EarlyTrigger. Well before the earliest contact
  // the real part allows.
  double min_travel_mm = 0;
  double retract_mm = 0;              // back along −direction after the contact, by the probe itself
  std::string tip;                    // the stylus tip that makes it; empty: whichever is active
};

}  // namespace cmm::planner
