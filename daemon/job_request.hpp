// What a job.submit asks for (docs/api.md, Job request), checked field by field so a bad request is
// refused with the JSON Pointer of its first bad field before anything is queued or moved.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/daemon_config.hpp"
#include "planner/inspection.hpp"
#include "planner/registration.hpp"

namespace cmm::daemon {

// Corners the scan gives, and where the operator roughly put them on the machine: the machine then
// probes each corner (and the fiducial) and T_M_S is fitted to what it measured.
struct PlateMeasurement {
  std::vector<int> ids;                  // 1-based plate corner ids
  std::vector<planner::Vec3> scan;       // S, parallel to ids
  std::vector<planner::Vec3> rough_machine;  // M, a few mm is good enough; parallel to ids
};

// The model the part should be (a CAD export), which verdicts are given against: in the reference's
// frame S as it is ("given"), or best-fitted onto the reference by point-to-plane ICP ("fit").
struct NominalRequest {
  std::string model;  // "sha256:…" or "file:…", as `model`
  double scale = 1;
  std::string placement = "given";
  bool scale_given = false;  // "scale" was in the request: its unit is the operator's word
};

struct JobRequest {
  std::string model;  // "sha256:<hex>" or "file:<name>"
  std::string name;
  double scale = 1;
  // The model's unit is the operator's word, not to be second-guessed by the unit check
  // (planner/model_units.hpp): "units_checked": true, or "scale" given at all (even 1).
  bool units_checked = false;
  bool scale_given = false;
  double delta_mm = 0.2;
  double spacing_mm = 2;
  double feature_angle_deg = 30;
  // For a raw scan (a model of points without faces, meshed by geometry::mesh_scan): ε, the mesh's
  // largest distance from the scanned surface; a bin size overriding the one ε gives; bins that
  // follow the curvature. Unset: geometry::ScanOptions' defaults. A mesh ignores them (the plan's
  // notes say so when they were given).
  std::optional<double> tolerance_mm;
  std::optional<double> bin_size_mm;
  bool adaptive = false;
  std::uint64_t seed = 1;
  // When the tip's qualification changed or vanished under the job (a controller restart): true,
  // the job qualifies the tip itself and goes on; false (the default), it pauses for the operator.
  bool requalify = false;
  // The tip the job measures with: "auto" lets cmmd choose per feature among the machine's qualified
  // tips (the configured active tip first: it registers the plate and takes every edge it can reach;
  // a bore goes to the largest ball that fits it); a tip's id measures everything with that tip.
  std::string tip = "auto";
  // A touch on a tip that was never qualified (its nominal radius and offset) only when the request
  // says so; every figure made with one then says so.
  bool allow_unqualified_tip = false;
  description::Plate plate;
  std::optional<NominalRequest> nominal;  // none: deviations against the scan only, no verdicts
  planner::Tolerances tolerances;         // the config's, overridden field by field by the request's
  planner::InspectionScope inspect;       // what the verdict covers (default: every feature)
  // Exactly one of these: corner pairs given, or the plate measured on the machine.
  std::optional<planner::RegistrationInput> given;
  std::optional<PlateMeasurement> measure;
};

// Throws RpcError invalid_params whose data.path is the JSON Pointer of the bad field. Defaults
// come from the config's job block and plate. plan.preview may leave the registration out
// (`registration_optional`); a job may not.
JobRequest parse_job_request(const nlohmann::json& params, const DaemonConfig& config,
                             bool registration_optional = false);

}  // namespace cmm::daemon
