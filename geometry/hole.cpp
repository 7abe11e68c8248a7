// Names of hole sources as they appear in the plan JSON.
#include "geometry/hole.hpp"

namespace cmm::geometry {

const char* to_string(HoleSource source) {
  return source == HoleSource::bore ? "bore" : "open_boundary";
}

}  // namespace cmm::geometry
