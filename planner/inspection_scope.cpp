// Which features a job inspects; see inspection_scope.hpp.
#include "planner/inspection_scope.hpp"

namespace cmm::planner {

namespace {

// The request's own reason for a feature it lists, or a plain one when it gave none.
std::string listed_reason(const InspectionScope& scope) {
  return scope.exclude_reason.empty() ? std::string("excluded by the request") : scope.exclude_reason;
}

}  // namespace

std::string edge_exclusion(const InspectionScope& scope, int id, int curve, bool probeable) {
  const bool asked = !scope.edge_points || scope.edge_points->contains(id) || scope.curves.contains(curve);
  if (!asked) return kNotAskedFor;
  if (scope.excluded_edge_points.contains(id) || scope.excluded_curves.contains(curve)) return listed_reason(scope);
  if (scope.exclude_not_probeable && !probeable) return kNotProbeable;
  return "";
}

std::string hole_exclusion(const InspectionScope& scope, int id, bool probeable) {
  if (scope.holes && !scope.holes->contains(id)) return kNotAskedFor;
  if (scope.excluded_holes.contains(id)) return listed_reason(scope);
  if (scope.exclude_not_probeable && !probeable) return kNotProbeable;
  return "";
}

}  // namespace cmm::planner
