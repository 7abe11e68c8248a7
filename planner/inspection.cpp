// The ISO 14253-1 decision rule, the tolerance lookups and the job verdict of planner/inspection.hpp.
#include "planner/inspection.hpp"

#include <cmath>
#include <string>

namespace cmm::planner {

const char* to_string(Verdict verdict) {
  switch (verdict) {
    case Verdict::pass: return "pass";
    case Verdict::fail: return "fail";
    case Verdict::undecided: return "undecided";
    case Verdict::incomplete: return "incomplete";
    case Verdict::not_measured: return "not_measured";
    case Verdict::excluded: return "excluded";
  }
  return "not_measured";
}

Verdict decide(double deviation_mm, double expanded_uncertainty_mm, const ToleranceZone& zone) {
  const double u = std::abs(expanded_uncertainty_mm);
  // Conformance is proven only when the whole uncertainty interval lies inside the zone, and
  // non-conformance only when it lies wholly outside; a NaN deviation proves neither.
  if (deviation_mm - u >= zone.lower_mm && deviation_mm + u <= zone.upper_mm) return Verdict::pass;
  if (deviation_mm + u < zone.lower_mm || deviation_mm - u > zone.upper_mm) return Verdict::fail;
  return Verdict::undecided;
}

double Tolerances::edge_profile_for(int edge_point_id, int curve) const {
  if (const auto point = edge_point_profile_mm.find(edge_point_id); point != edge_point_profile_mm.end())
    return point->second;
  if (const auto c = curve_profile_mm.find(curve); c != curve_profile_mm.end()) return c->second;
  return edge_profile_mm;
}

const HoleTolerance& Tolerances::hole_for(int hole_id) const {
  const auto it = hole_overrides.find(hole_id);
  return it == hole_overrides.end() ? hole : it->second;
}

double expanded_uncertainty(const Tolerances& tolerances, double sigma_mm) {
  return tolerances.coverage_factor * std::hypot(sigma_mm, tolerances.machine_uncertainty_mm);
}

Verdict worse(Verdict a, Verdict b) {
  const auto rank = [](Verdict v) {
    switch (v) {
      case Verdict::fail: return 5;
      case Verdict::incomplete: return 4;
      case Verdict::not_measured: return 3;
      case Verdict::undecided: return 2;
      case Verdict::pass: return 1;
      case Verdict::excluded: return 0;
    }
    return 0;
  };
  return rank(a) >= rank(b) ? a : b;
}

void VerdictCounts::add(Verdict verdict) {
  switch (verdict) {
    case Verdict::pass: ++pass; break;
    case Verdict::fail: ++fail; break;
    case Verdict::undecided: ++undecided; break;
    case Verdict::incomplete:
    case Verdict::not_measured: ++not_measured; break;
    case Verdict::excluded: ++excluded; break;
  }
}

Verdict job_verdict(const VerdictCounts& edges, const VerdictCounts& holes) {
  if (edges.fail + holes.fail > 0) return Verdict::fail;
  // Nothing judged is no pass either: a job that measured nothing it was asked for (or was asked for
  // nothing) says so instead of passing by omission.
  if (edges.not_measured + holes.not_measured > 0 || edges.measured() + holes.measured() == 0) return Verdict::incomplete;
  if (edges.undecided + holes.undecided > 0) return Verdict::undecided;
  return Verdict::pass;
}

std::string coverage_text(const InspectionResult& inspection) {
  const auto measured = [](const VerdictCounts& c, const char* what) {
    std::string text = std::to_string(c.measured()) + " of " + std::to_string(c.inspected()) + " inspected " + what + " measured";
    if (c.not_measured > 0) text += " (" + std::to_string(c.not_measured) + " not measured)";
    return text;
  };
  std::string text = measured(inspection.edge_counts, "edge points") + ", " + measured(inspection.hole_counts, "holes");
  const char* separator = "; ";
  for (const Exclusion& e : inspection.exclusions) {
    text += separator;
    separator = ", ";
    if (e.edge_points > 0) text += std::to_string(e.edge_points) + (e.edge_points == 1 ? " edge point" : " edge points");
    if (e.edge_points > 0 && e.holes > 0) text += " and ";
    if (e.holes > 0) text += std::to_string(e.holes) + (e.holes == 1 ? " hole" : " holes");
    text += " excluded (" + e.reason + ")";
  }
  return text;
}

}  // namespace cmm::planner
