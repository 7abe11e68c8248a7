// The machine-free steps of a job: the reference model for a request, the description a plan is
// made for, and the plan.
#include "daemon/job_planning.hpp"

#include "daemon/client/rpc_error.hpp"

namespace cmm::daemon {

ReferenceModel load_reference_model(const std::filesystem::path& file, const JobRequest& request,
                                    const description::TravelBox& travel_box, const geometry::CancelCheck& cancel,
                                    bool made_from_scan) {
  planner::ReferenceModelOptions options;
  options.scale = request.scale;
  options.spacing = request.spacing_mm;
  options.feature_angle_deg = request.feature_angle_deg;
  options.cancel = cancel;
  if (request.tolerance_mm) options.scan.tolerance_mm = *request.tolerance_mm;
  options.scan.bin_size_mm = request.bin_size_mm;
  options.scan.adaptive = request.adaptive;
  options.scan.cancel = cancel;
  options.made_from_scan = made_from_scan;
  try {
    ReferenceModel m = planner::load_reference_model(file, travel_box, options);
    planner::settle_delta(m.inputs, request.delta_mm, "job request (or cmmd.json's job.delta_mm)", m.features);
    if (!m.scan && (request.tolerance_mm || request.bin_size_mm || request.adaptive))
      m.inputs.notes.push_back("tolerance_mm, bin_size_mm and adaptive apply to a raw scan; " + file.filename().string() +
                               " is a mesh, planned on as it is");
    return m;
  } catch (const planner::ModelError& e) {
    nlohmann::json data = {{"file", e.file.string()}, {"kind", planner::to_string(e.kind)}};
    if (e.kind == planner::ModelError::Kind::too_many_points) data.update({{"points", e.points}, {"limit", e.limit}});
    throw RpcError(rpc_code::model_error, e.what(), data);
  }
}

description::MachineDescription machine_for_job(const description::MachineDescription& configured,
                                                const description::MachineDescription& reported) {
  description::MachineDescription machine = configured;
  for (const description::StylusTip& tip : reported.tips)
    for (description::StylusTip& described : machine.tips)
      if (described.id == tip.id) {
        described.ball_radius_mm = tip.ball_radius_mm;
        described.offset = tip.offset;
        described.qualification = tip.qualification;
      }
  if (!reported.active_tip.empty()) machine.active_tip = reported.active_tip;
  // The plan keeps to where both the description and the machine itself say the ball may go: a
  // controller configured with tighter soft limits than machine.json must not fault mid-job.
  const description::TravelBox& box = reported.travel_box;
  if ((box.max.array() > box.min.array()).all()) {
    machine.travel_box.min = machine.travel_box.min.cwiseMax(box.min);
    machine.travel_box.max = machine.travel_box.max.cwiseMin(box.max);
  }
  return machine;
}

std::vector<std::string> job_tips(const JobRequest& request, const description::MachineDescription& configured,
                                  const description::MachineDescription& reported, std::vector<std::string>* left_out) {
  if (request.tip != "auto") return {request.tip};
  const std::string primary = configured.find_tip(configured.active_tip) ? configured.active_tip : reported.active_tip;
  std::vector<std::string> tips{primary};
  for (const description::StylusTip& t : reported.tips) {
    if (t.id == primary) continue;
    if (t.qualification || request.allow_unqualified_tip) tips.push_back(t.id);
    else if (left_out) left_out->push_back("tip " + t.id + " is not qualified, so the job does not use it");
  }
  return tips;
}

planner::MeasurementPlan plan_job(const ReferenceModel& model, const Eigen::Isometry3d& T_M_S,
                                  const description::MachineDescription& machine,
                                  const geometry::CancelCheck& cancel, std::vector<std::string> tips) {
  planner::MeasurementPlanOptions options;
  options.tips = std::move(tips);
  options.touch.radius = machine.tip().ball_radius_mm;
  options.touch.delta = model.inputs.delta;
  options.cancel = cancel;
  try {
    return planner::plan_measurement(model.features, model.mesh, T_M_S, machine, options);
  } catch (const geometry::Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    throw RpcError(rpc_code::planning_error, std::string("cannot plan the job: ") + e.what());
  }
}

}  // namespace cmm::daemon
