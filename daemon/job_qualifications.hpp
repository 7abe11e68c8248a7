// The tip qualifications a job's touches were made under (qualifications.json in its folder): the
// one in force when the job began, and each one it took on since (the tip qualified again during a
// hold, or by the job itself). Each journal line names its entry, so every touch is compensated with
// the radius qualified for it, and the result says which touches each qualification covers.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hal/description/machine_description.hpp"

namespace cmm::daemon {

struct QualificationInForce {
  std::string tip;             // the stylus tip it belongs to
  double ball_radius_mm = 0;   // the tip's radius as the machine reported it
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  std::optional<description::TipQualification> qualification;  // empty: the tip's nominal values, never qualified
  std::string source;     // why the job took it on: "in force when the job began", …
  std::string since_utc;  // when the job took it on
};

struct JobQualifications {
  std::string tip;  // the job's primary tip: the one it registers with and measures edges with
  std::vector<QualificationInForce> list;  // index = a journal line's "q"; every tip the job used, in order
  // A tip the job asked the operator to fit by hand (a machine without a tool changer), and when: the
  // run after the resume selects it and holds it to a qualification made since.
  std::optional<std::string> fitting;
  std::string fitting_since_utc;

  // The entry the touches of `tip_id` are made under now: its last one; nullopt before its first.
  std::optional<int> current(const std::string& tip_id) const;
};

// What the machine reports for `tip` now, as an entry with `source`.
QualificationInForce in_force(const description::StylusTip& tip, std::string source);

// Whether the machine's tip `now` is still the one in force (both of the same tip id) is still the one in force: same radius, offset and qualification time
// stamp (to 1e-7 mm: the values come through the same wire both times), and qualified on both sides
// or on neither.
bool same_qualification(const QualificationInForce& in_force, const description::StylusTip& now);

// One line for reasons and notes: "r 0.998512 mm, qualified 2026-11-24T12:00:00Z" or "r 1 mm
// nominal (never qualified)".
std::string describe(const QualificationInForce& q);

nlohmann::json to_json(const JobQualifications& q);
// Throws nlohmann::json::exception (or std::invalid_argument: an empty list) for a file that is not one.
JobQualifications job_qualifications_from_json(const nlohmann::json& j);

}  // namespace cmm::daemon
