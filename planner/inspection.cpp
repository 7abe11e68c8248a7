// The ISO 14253-1 decision rule and the tolerance lookups of planner/inspection.hpp.
#include "planner/inspection.hpp"

#include <cmath>

namespace cmm::planner {

const char* to_string(Verdict verdict) {
  switch (verdict) {
    case Verdict::pass: return "pass";
    case Verdict::fail: return "fail";
    case Verdict::undecided: return "undecided";
    case Verdict::not_measured: return "not_measured";
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
      case Verdict::fail: return 3;
      case Verdict::undecided: return 2;
      case Verdict::pass: return 1;
      case Verdict::not_measured: return 0;
    }
    return 0;
  };
  return rank(a) >= rank(b) ? a : b;
}

}  // namespace cmm::planner
