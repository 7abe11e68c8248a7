// Edge points against the nominal's nearest sharp edge, bores against the nominal's hole on their axis.
#include "planner/inspect.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {

void count(VerdictCounts& counts, Verdict verdict) {
  switch (verdict) {
    case Verdict::pass: ++counts.pass; break;
    case Verdict::fail: ++counts.fail; break;
    case Verdict::undecided: ++counts.undecided; break;
    case Verdict::not_measured: ++counts.not_measured; break;
  }
}

Verdict job_verdict(const VerdictCounts& edges, const VerdictCounts& holes) {
  if (edges.fail + holes.fail > 0) return Verdict::fail;
  if (edges.undecided + holes.undecided > 0) return Verdict::undecided;
  if (edges.pass + holes.pass > 0) return Verdict::pass;
  return Verdict::not_measured;
}

EdgeInspection inspect_edge(const EdgeResult& edge, int curve, const NominalModel& nominal, const Tolerances& tolerances) {
  EdgeInspection out;
  out.id = edge.id;
  const double t = tolerances.edge_profile_for(edge.id, curve);
  out.profile.zone = {-t, t};
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

HoleInspection inspect_hole(const HoleResult& hole, const NominalModel& nominal, const Tolerances& tolerances) {
  HoleInspection out;
  out.id = hole.id;
  const HoleTolerance& tolerance = tolerances.hole_for(hole.id);
  out.diameter.zone = tolerance.diameter;
  out.position.zone = {0, tolerance.position_mm};
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
                         const NominalModel& nominal, const Tolerances& tolerances, const NominalPlacement& placement) {
  InspectionResult out;
  out.nominal = placement;
  out.tolerances = tolerances;
  for (const EdgeResult& edge : result.edges) {
    const int curve = edge.id >= 0 && static_cast<std::size_t>(edge.id) < reference_points.size()
                          ? reference_points[static_cast<std::size_t>(edge.id)].curve
                          : -1;
    out.edges.push_back(inspect_edge(edge, curve, nominal, tolerances));
    count(out.edge_counts, out.edges.back().profile.verdict);
  }
  for (const HoleResult& hole : result.holes) {
    out.holes.push_back(inspect_hole(hole, nominal, tolerances));
    count(out.hole_counts, worse(out.holes.back().diameter.verdict, out.holes.back().position.verdict));
  }
  out.verdict = job_verdict(out.edge_counts, out.hole_counts);
  return out;
}

}  // namespace cmm::planner
