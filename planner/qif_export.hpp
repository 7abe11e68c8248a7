// A job's result as one QIF 3.0 results document (ISO 23952): machine and tip, registration, measured
// features and, against a nominal model, characteristics with tolerances and verdicts (docs/qif.md).
#pragma once

#include <string>

#include "planner/measurement_result.hpp"

namespace cmm::planner {

// What the document states that the result does not carry. Text is free (it is escaped); time
// stamps are ISO 8601 date-times as hal::utc_now() writes them ("2026-11-24T12:00:00Z"), empty
// when unknown (the element is then left out).
struct QifContext {
  std::string job_id;        // InspectionTraceability/ReportNumber
  std::string job_name;      // the operator's name of the job
  std::string part_name;     // Product/Part (the job's name or its model's)
  std::string cmmd_version;  // "0.4.0"
  std::string station;       // where the machine stands: the CMM's Location

  struct Machine {
    std::string name;  // "Modbus machine at 10.0.0.5:502"
    // The travel box in M; written (as the working volume) only when max > min on every axis.
    Vec3 travel_min_M = Vec3::Zero(), travel_max_M = Vec3::Zero();
  } machine;

  struct Tip {
    std::string id;             // "T1"
    double ball_radius_mm = 0;  // the qualified effective radius; 0: the result's ball_radius_mm
    Vec3 offset_M = Vec3::Zero();          // the qualified offset from the probe head
    std::string qualified_utc;             // empty: no qualification is written
    double qualification_residual_mm = 0;  // RMS of the qualification's sphere fit
  } tip;

  std::string started_utc, finished_utc;  // the measurement's start and end
  std::string written_utc;                // when this document is written (Version/TimeCreated)
  std::string nominal_model;              // the job's nominal ("sha256:…", "file:…"); empty: none
};

// The QIFDocument text (UTF-8). Features and positions are in S, the document's common coordinate
// system; T_M_S (and, with an inspection, T_M_N = T_M_S·T_S_N) are its actual transforms. With an
// inspection, every edge point and hole gets its characteristics (a feature not measured: status
// NOT_ANALYZED and no value); without one, only measured features are written and no
// characteristics (the deviations against the scan carry no verdict). Throws std::invalid_argument
// naming the field for a non-empty time stamp that is not an ISO 8601 date-time and for a
// non-finite number it would have to write.
std::string to_qif(const MeasurementResult& result, const QifContext& context);

}  // namespace cmm::planner
