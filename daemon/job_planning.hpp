// The machine-free steps of a job, shared by the job runner and plan.preview: read the reference
// mesh, extract its features, and plan the touches for the active tip once T_M_S is known.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "daemon/job_request.hpp"
#include "geometry/cancellation.hpp"
#include "geometry/feature_model.hpp"
#include "hal/description/machine_description.hpp"
#include "hal/description/machine_description.hpp"
#include "planner/measurement_plan.hpp"
#include "planner/plan_json.hpp"
#include "planner/reference_model.hpp"

namespace cmm::daemon {

using planner::ReferenceModel;

// planner::load_reference_model with the request's scale, spacing, angle and scan options (and its δ
// recorded for the plan): a ModelError becomes RpcError model_error, data {"file", "kind"} (and
// "points", "limit" for too many points); geometry::Cancelled when `cancel` asks, in the scan front
// end too. `made_from_scan`: the file is a mesh the scan front end made (a job's stored reference.ply).
ReferenceModel load_reference_model(const std::filesystem::path& file, const JobRequest& request,
                                    const description::TravelBox& travel_box, const geometry::CancelCheck& cancel = {},
                                    bool made_from_scan = false);

// The description the plan is made for: the configured one (which knows the styli's shafts), with
// the tips' radii, offsets and qualifications and the active tip as the machine reports them (a job
// uses the active tip's qualified radius, DESIGN.md), and the travel box cut down to the machine's
// own where that is smaller.
description::MachineDescription machine_for_job(const description::MachineDescription& configured,
                                                const description::MachineDescription& reported);

// For the δ the model was loaded with (its inputs), with the active tip's radius. Throws RpcError
// planning_error when the plan cannot be made; geometry::Cancelled when `cancel` asks.
// The tips a job that registers now plans with, the primary first: the one the request names; or, for
// "auto", the configured active tip and every other tip `reported` qualified (any tip, when the
// request allows unqualified ones). `left_out` gets a line for each tip not used and why.
std::vector<std::string> job_tips(const JobRequest& request, const description::MachineDescription& configured,
                                  const description::MachineDescription& reported, std::vector<std::string>* left_out = nullptr);

// `tips`: the tips the plan may use, the primary first (planner::MeasurementPlanOptions::tips); empty:
// the active tip alone.
planner::MeasurementPlan plan_job(const ReferenceModel& model, const Eigen::Isometry3d& T_M_S,
                                  const description::MachineDescription& machine,
                                  const geometry::CancelCheck& cancel = {}, std::vector<std::string> tips = {});

}  // namespace cmm::daemon
