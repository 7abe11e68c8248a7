// Names of touch targets, as the plan JSON spells them.
#include "planner/touch.hpp"

namespace cmm::planner {

const char* to_string(TouchTarget target) {
  switch (target) {
    case TouchTarget::edge: return "edge";
    case TouchTarget::face: return "face";
    case TouchTarget::bore: return "bore";
    case TouchTarget::plate_face: return "plate_face";
    case TouchTarget::fiducial: return "fiducial";
  }
  return "?";
}

}  // namespace cmm::planner
