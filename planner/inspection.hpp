// Inspection: the tolerances a job states and the verdicts its measured features get by the
// ISO 14253-1 decision rule, against a nominal model (a CAD export), never against the scan.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/mesh.hpp"
#include "planner/inspection_scope.hpp"

namespace cmm::planner {

using geometry::Vec3;

// A characteristic's conformance by ISO 14253-1 with the expanded uncertainty U of its measurement:
// pass when the whole interval deviation ± U lies inside the tolerance, fail when it lies wholly
// outside, undecided when it straddles a limit; not_measured when the job was asked to inspect it and
// has no measurement, excluded when the request left it out on purpose (the reason says why).
// A job's verdict is pass, fail, undecided or incomplete: incomplete when a characteristic it was
// asked to inspect was not measured (or none was), so that omission never reads as a pass.
enum class Verdict { pass, fail, undecided, incomplete, not_measured, excluded };
const char* to_string(Verdict verdict);
// A characteristic's verdict that rests on a measurement: pass, fail or undecided.
inline bool judged(Verdict verdict) {
  return verdict == Verdict::pass || verdict == Verdict::fail || verdict == Verdict::undecided;
}

// Limits on a deviation, lower ≤ upper (a symmetric ± t is {−t, +t}).
struct ToleranceZone {
  double lower_mm = 0, upper_mm = 0;
  bool operator==(const ToleranceZone&) const = default;
};

// The decision rule itself: deviation and U in mm, U ≥ 0.
Verdict decide(double deviation_mm, double expanded_uncertainty_mm, const ToleranceZone& zone);

struct HoleTolerance {
  ToleranceZone diameter{-0.05, 0.05};  // measured − nominal diameter
  // Position: the diameter of the cylindrical zone around the nominal axis that the measured
  // centre must lie in (ISO 1101); its deviation is 2 × the centre's offset across the axis.
  double position_mm = 0.1;
  bool operator==(const HoleTolerance&) const = default;
};

// What a job asks (job.submit "tolerances", defaults from cmmd.json "tolerances").
struct Tolerances {
  double edge_profile_mm = 0.1;      // ± on an edge point's signed deviation from the nominal edge
  std::map<int, double> edge_point_profile_mm;  // per edge point id: overrides the curve's and the default
  std::map<int, double> curve_profile_mm;       // per feature curve id
  HoleTolerance hole;
  std::map<int, HoleTolerance> hole_overrides;  // per hole id (the reference model's)
  double coverage_factor = 2;        // k: U = k · u
  // The machine's own standard uncertainty beyond the trigger noise (probing error, scales), added
  // in quadrature to each feature's trigger-noise σ: u = √(σ² + u_machine²).
  double machine_uncertainty_mm = 0.0015;
  bool operator==(const Tolerances&) const = default;

  double edge_profile_for(int edge_point_id, int curve) const;  // the zone's half-width that applies
  const HoleTolerance& hole_for(int hole_id) const;
};

// The expanded uncertainty of a feature whose trigger-noise σ is `sigma_mm`.
double expanded_uncertainty(const Tolerances& tolerances, double sigma_mm);

// A deviation, the tolerance it is held against and the verdict.
struct Characteristic {
  double deviation_mm = 0;
  double uncertainty_mm = 0;  // U
  ToleranceZone zone;
  Verdict verdict = Verdict::not_measured;
};

// An edge point against the nominal model: the nearest point of the nominal's sharp edges (or
// surface, when no sharp edge of the nominal lies within reach) and the signed deviation, with the
// sign convention of the reference deviation (docs/result.md): positive outside the nominal.
struct EdgeInspection {
  int id = -1;
  std::optional<Vec3> nominal_S;   // the nominal edge point the measured point is held against
  Characteristic profile;          // deviation = signed distance, zone = ± edge_profile_for
  std::string reason;              // why not measured / why no nominal was found
};

struct HoleInspection {
  int id = -1;
  std::optional<Vec3> nominal_centre_S;
  std::optional<Vec3> nominal_axis_S;
  double nominal_diameter_mm = 0;
  Characteristic diameter;  // deviation = measured − nominal diameter
  Characteristic position;  // deviation = 2 × |centre offset across the nominal axis| (a zone diameter), zone {0, t}
  std::string reason;
};

// How the nominal model was placed in the reference's frame S.
struct NominalPlacement {
  std::string model;               // the job's name of it ("sha256:…", "file:…")
  std::string method;              // "given" (already in S) or "icp" (point-to-plane ICP onto the reference)
  Eigen::Isometry3d T_S_N = Eigen::Isometry3d::Identity();  // nominal frame → S
  int iterations = 0;
  bool converged = true;
  double rms_mm = 0;               // ICP: point-to-plane RMS of the nominal's samples against the reference at the end
  double overlap = 1;              // ICP: share of samples paired within the rejection distance
};

// Features by verdict (a hole counts once, by its worse characteristic). `excluded` ones were left
// out on purpose and are no part of the verdict; `not_measured` ones were asked for and make it incomplete.
struct VerdictCounts {
  int pass = 0, fail = 0, undecided = 0, not_measured = 0, excluded = 0;
  void add(Verdict verdict);  // incomplete counts as not_measured
  int inspected() const { return pass + fail + undecided + not_measured; }  // asked for
  int measured() const { return pass + fail + undecided; }                  // asked for and judged
};

// How many features were left out on purpose for one reason ("not asked for", "not probeable in
// this set-up", a request's own reason).
struct Exclusion {
  std::string reason;
  int edge_points = 0, holes = 0;
};

// The job's inspection: present only when the job named a nominal model.
struct InspectionResult {
  NominalPlacement nominal;
  Tolerances tolerances;
  InspectionScope scope;              // what the job was asked to inspect
  std::vector<EdgeInspection> edges;  // one per result edge point, same order
  std::vector<HoleInspection> holes;  // one per result hole, same order
  VerdictCounts edge_counts, hole_counts;  // a hole counts once: its worse characteristic
  std::vector<Exclusion> exclusions;       // the excluded features by reason, in the order first met
  std::vector<std::string> notes;          // e.g. an id the request named that the model does not have
  Verdict verdict = Verdict::incomplete;   // job_verdict(edge_counts, hole_counts)
};

// fail > incomplete > not_measured > undecided > pass > excluded: a feature with one characteristic
// not measured is not measured, whatever its other one says; an excluded one decides nothing.
Verdict worse(Verdict a, Verdict b);

// The job's verdict: fail if any feature fails; else incomplete if any feature asked for was not
// measured, or none was measured at all; else undecided if any is; else pass.
Verdict job_verdict(const VerdictCounts& edges, const VerdictCounts& holes);

// The verdict's coverage in one line, as every output prints it after the verdict: "340 of 342
// inspected edge points measured (2 not measured), 3 of 3 inspected holes measured; 379 edge points,
// 2 holes excluded (not probeable in this set-up)".
std::string coverage_text(const InspectionResult& inspection);

}  // namespace cmm::planner
