// A job's result files from its plan and the touches the machine made: result.json, result.csv and
// the merged cloud (docs/result.md), with what traceability needs (versions, hashes, tip, seeds).
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "daemon/daemon_config.hpp"
#include "daemon/job_planning.hpp"
#include "daemon/job_qualifications.hpp"
#include "daemon/job_registration.hpp"
#include "daemon/job_store.hpp"
#include "daemon/model_store.hpp"
#include "hal/description/machine_description.hpp"
#include "hal/motion.hpp"
#include "planner/plan_compensation.hpp"
#include "planner/touch.hpp"

namespace cmm::daemon {

struct JobResultInputs {
  const ReferenceModel& model;
  const planner::MeasurementPlan& plan;
  const description::MachineDescription& machine;
  const JobRequest& request;
  const DaemonConfig& config;
  const JobRegistration& registration;
  std::map<int, hal::TouchResult> touches;  // by plan touch id
  // The tip qualifications the touches were made under (null: not recorded, a job from before they
  // were), and which one each touch was made under (by plan touch id; missing: the first).
  const JobQualifications* qualifications = nullptr;
  std::map<int, int> touch_qualification;
  description::StylusTip tip;            // the active tip, with its qualification
  double machine_time_s = 0;   // machine clock from registering to the end of the program, this run
  double probing_time_s = 0;   // of which the probing, to hold against the plan's estimate
  std::string version;         // cmmd's
  // Where the mesh the job planned on came from (JobReference::provenance); null when not known.
  nlohmann::json reference_mesh = nullptr;
  std::string started_utc, finished_utc;
  // Where the request's nominal model is read from (null: the job is not held against one).
  const ModelStore* models = nullptr;
};

// The touch results as compensation takes them, each for the radius R its tip was planned with
// (`planned_radius`, by tip id; a touch of a tip not in it keeps its centre): a touch made under a
// qualification of radius r is moved by (r − R) along its planned approach, which keeps its contact
// point (docs/result.md, Traceability). By plan touch id.
std::map<int, planner::TouchOutcome> touches_at_radius(const std::vector<planner::Touch>& planned,
                                                       const std::map<int, hal::TouchResult>& touches,
                                                       const std::map<int, int>& touch_qualification,
                                                       const JobQualifications* qualifications,
                                                       const std::map<std::string, double>& planned_radius);

// Writes the files into the job's folder (each atomically) and returns a one-line summary for the
// job record's reason ("212 edge points measured, 0 failed; deviation RMS 0.012 mm, max 0.031 mm").
// Every touch is compensated with the radius of the qualification it was made under
// (touches_at_radius). result.json is written last, so a job folder with result.json holds the
// whole result.
std::string write_job_result(JobStore& store, int job_id, const JobResultInputs& inputs);

}  // namespace cmm::daemon
