// A job's report as one self-contained HTML document (inline CSS with a print stylesheet, the
// colour map as an embedded PNG, the histogram as inline SVG; no script, no external file), which
// any browser prints to PDF. What it holds and how: docs/report.md.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/mesh.hpp"
#include "hal/description/machine_description.hpp"
#include "planner/measurement_result.hpp"

namespace cmm::planner {

struct ReportMachine {
  std::string driver;  // cmmd.json's machine.driver: "sim", "modbus", "grbl", "ippdme"
  std::string name;    // the machine description's name
  description::TravelBox travel_box;  // M, mm
};

struct ReportTip {
  std::string id;
  double nominal_ball_radius_mm = 0;                       // machine.json's
  geometry::Vec3 nominal_offset = geometry::Vec3::Zero();  // machine.json's, M axes
  // What qualification measured (radius, offset, residual, time); empty: never qualified, the
  // nominal values were used.
  std::optional<description::TipQualification> qualification;
};

struct CornerResidual {
  int id = 0;              // the plate's corner id
  double residual_mm = 0;  // |M corner − T_M_S · S corner|
};

struct ReportRegistration {
  std::string method;  // "given" (the request's corners) or "measured" (the machine touched the plate)
  Eigen::Isometry3d T_M_S = Eigen::Isometry3d::Identity();
  std::vector<CornerResidual> corners;
  double rms_mm = 0;
};

struct ReportInputs {
  int job_id = 0;
  std::string job_name;  // user input: escaped wherever it is written
  std::string state;     // the job's state ("done", "failed", …)
  std::string state_reason;
  std::string model;     // the reference model ("sha256:…", "file:…")
  std::optional<std::string> nominal_model;  // the job's nominal, when it named one
  std::string station;   // which station measured (host or configured name)
  std::string cmmd_version;
  std::string created_utc, finished_utc;  // ISO 8601
  ReportMachine machine;
  ReportTip tip;
  ReportRegistration registration;
  MeasurementResult result;  // with `inspection` when the job had a nominal
  const geometry::TriangleMesh* reference_mesh = nullptr;  // S; null: the picture shows the points alone
  std::vector<std::string> notes;  // the job's own, beside the result's
};

// The whole document, UTF-8. Every text from outside is escaped; lengths in mm with 4 decimals.
std::string render_report(const ReportInputs& inputs);

}  // namespace cmm::planner
