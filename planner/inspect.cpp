// Edge points against the nominal's nearest sharp edge, bores against the nominal's hole on their axis.
#include "planner/inspect.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <string>

#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {

// A feature left out of the scope: excluded, with the scope's reason and, for one the plan could not
// probe, the plan's own; counted under the scope's reason.
std::string excluded_reason(const std::string& cause, const std::string& plan_reason, bool is_edge, InspectionResult& out) {
  auto group = std::find_if(out.exclusions.begin(), out.exclusions.end(), [&](const Exclusion& e) { return e.reason == cause; });
  if (group == out.exclusions.end()) group = out.exclusions.insert(out.exclusions.end(), Exclusion{cause});
  ++(is_edge ? group->edge_points : group->holes);
  return cause == kNotProbeable && !plan_reason.empty() ? cause + ": " + plan_reason : cause;
}

// The scope's ids that name no feature of the model: asked for in vain, which the result says.
void note_unknown_ids(const std::set<int>& ids, std::size_t count, const char* what, std::vector<std::string>& notes) {
  for (int id : ids)
    if (id < 0 || static_cast<std::size_t>(id) >= count)
      notes.push_back(std::string("inspect: the model has no ") + what + " " + std::to_string(id));
}

// `excluded`: why the scope leaves the point out ("" when it does not).
EdgeInspection inspect_edge(const EdgeResult& edge, int curve, const NominalModel& nominal, const Tolerances& tolerances,
                            const std::string& excluded) {
  EdgeInspection out;
  out.id = edge.id;
  const double t = tolerances.edge_profile_for(edge.id, curve);
  out.profile.zone = {-t, t};
  if (!excluded.empty()) {
    out.profile.verdict = Verdict::excluded;
    out.reason = excluded;
    return out;
  }
  if (edge.status != FeatureStatus::measured || !edge.scan) {
    out.reason = edge.reason.empty() ? "not measured" : edge.reason;
    return out;
  }
  const Vec3 x = edge.scan->position;
  const double reach = nominal_edge_reach_mm(tolerances, t);
  const auto nearest = nearest_nominal_edge(nominal, x, reach);
  if (!nearest) {
    out.reason = "no sharp edge of the nominal within " + fixed(reach, 3) + " mm of the measured point";
    return out;
  }
  const NominalEdge& e = *nearest->edge;
  const Vec3 tangent = (e.b - e.a).normalized();
  out.nominal_S = nearest->point;
  try {
    out.profile.deviation_mm = signed_deviation(x, nearest->point, e.n_first, e.n_second, tangent).signed_mm;
  } catch (const std::exception& error) {
    out.reason = std::string("the nominal edge there has no outside: ") + error.what();
    return out;
  }
  out.profile.uncertainty_mm = expanded_uncertainty(tolerances, edge.scan->sigma_mm);
  out.profile.verdict = decide(out.profile.deviation_mm, out.profile.uncertainty_mm, out.profile.zone);
  return out;
}

HoleInspection inspect_hole(const HoleResult& hole, const NominalModel& nominal, const Tolerances& tolerances,
                            const std::string& excluded) {
  HoleInspection out;
  out.id = hole.id;
  const HoleTolerance& tolerance = tolerances.hole_for(hole.id);
  out.diameter.zone = tolerance.diameter;
  out.position.zone = {0, tolerance.position_mm};
  if (!excluded.empty()) {
    out.diameter.verdict = out.position.verdict = Verdict::excluded;
    out.reason = excluded;
    return out;
  }
  if (hole.status != FeatureStatus::measured || !hole.scan) {
    out.reason = hole.reason.empty() ? "not measured" : hole.reason;
    return out;
  }
  const std::optional<NominalHole> match =
      nominal_hole_near(nominal, hole.nominal_centre, hole.nominal_axis, hole.nominal_diameter_mm / 2);
  if (!match) {
    out.reason = "the nominal has no circular sharp edge around this hole's rim";
    return out;
  }
  out.nominal_centre_S = match->centre;
  out.nominal_axis_S = match->axis;
  out.nominal_diameter_mm = 2 * match->radius;
  out.diameter.deviation_mm = hole.scan->diameter_mm - out.nominal_diameter_mm;
  out.diameter.uncertainty_mm = expanded_uncertainty(tolerances, hole.scan->diameter_sigma_mm);
  out.diameter.verdict = decide(out.diameter.deviation_mm, out.diameter.uncertainty_mm, out.diameter.zone);
  const Vec3 v = hole.scan->centre - match->centre;
  out.position.deviation_mm = 2 * (v - v.dot(match->axis) * match->axis).norm();
  out.position.uncertainty_mm = 2 * expanded_uncertainty(tolerances, hole.scan->centre_sigma_mm);
  // A position zone has one limit: a centre on the axis is the best there is, not one near a limit.
  out.position.verdict = decide(out.position.deviation_mm, out.position.uncertainty_mm,
                                {-std::numeric_limits<double>::infinity(), tolerance.position_mm});
  return out;
}

}  // namespace

double nominal_edge_reach_mm(const Tolerances& tolerances, double profile_mm) {
  return std::max({1.0, 10 * profile_mm, 10 * tolerances.machine_uncertainty_mm});
}

InspectionResult inspect(const MeasurementResult& result, const std::vector<geometry::EdgePoint>& reference_points,
                         const NominalModel& nominal, const Tolerances& tolerances, const NominalPlacement& placement,
                         const InspectionScope& scope) {
  InspectionResult out;
  out.nominal = placement;
  out.tolerances = tolerances;
  out.scope = scope;
  for (const EdgeResult& edge : result.edges) {
    const int curve = edge.id >= 0 && static_cast<std::size_t>(edge.id) < reference_points.size()
                          ? reference_points[static_cast<std::size_t>(edge.id)].curve
                          : -1;
    const std::string cause = edge_exclusion(scope, edge.id, curve, edge.status != FeatureStatus::not_planned);
    const std::string excluded = cause.empty() ? cause : excluded_reason(cause, edge.reason, true, out);
    out.edges.push_back(inspect_edge(edge, curve, nominal, tolerances, excluded));
    out.edge_counts.add(out.edges.back().profile.verdict);
  }
  for (const HoleResult& hole : result.holes) {
    const std::string cause = hole_exclusion(scope, hole.id, hole.status != FeatureStatus::not_planned);
    const std::string excluded = cause.empty() ? cause : excluded_reason(cause, hole.reason, false, out);
    out.holes.push_back(inspect_hole(hole, nominal, tolerances, excluded));
    out.hole_counts.add(worse(out.holes.back().diameter.verdict, out.holes.back().position.verdict));
  }
  note_unknown_ids(scope.edge_points.value_or(std::set<int>()), result.edges.size(), "edge point", out.notes);
  note_unknown_ids(scope.excluded_edge_points, result.edges.size(), "edge point", out.notes);
  note_unknown_ids(scope.holes.value_or(std::set<int>()), result.holes.size(), "hole", out.notes);
  note_unknown_ids(scope.excluded_holes, result.holes.size(), "hole", out.notes);
  out.verdict = job_verdict(out.edge_counts, out.hole_counts);
  return out;
}

}  // namespace cmm::planner
