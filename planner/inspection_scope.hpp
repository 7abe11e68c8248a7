// What a job is asked to inspect (job.submit "inspect", docs/api.md): every feature by default, or
// chosen edge points, feature curves and holes, less the ones left out on purpose with a reason. A
// feature left out is counted `excluded` with that reason; one asked for and not measured makes the
// job incomplete.
#pragma once

#include <optional>
#include <set>
#include <string>

namespace cmm::planner {

struct InspectionScope {
  // Asked for: nullopt is every one, an empty set none. Edge points on `curves` are asked for too.
  std::optional<std::set<int>> edge_points;
  std::set<int> curves;
  std::optional<std::set<int>> holes;
  // Left out on purpose: the features the plan found no way to probe in this set-up (an edge standing
  // on the plate, a bore the head cannot enter), each with the plan's reason; and the listed ones,
  // with `exclude_reason`.
  bool exclude_not_probeable = false;
  std::set<int> excluded_edge_points, excluded_curves, excluded_holes;
  std::string exclude_reason;
  bool operator==(const InspectionScope&) const = default;

  bool everything() const { return *this == InspectionScope(); }
};

// Why a feature is not inspected, or "" when it is. `curve` is the edge point's feature curve (−1:
// none), `probeable` false when the plan could not measure the feature.
std::string edge_exclusion(const InspectionScope& scope, int id, int curve, bool probeable);
std::string hole_exclusion(const InspectionScope& scope, int id, bool probeable);

// The reasons the functions above give, for the coverage line's groups.
inline constexpr const char* kNotAskedFor = "not asked for";
inline constexpr const char* kNotProbeable = "not probeable in this set-up";

}  // namespace cmm::planner
