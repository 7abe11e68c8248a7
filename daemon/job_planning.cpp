#include "daemon/job_planning.hpp"

#include <cmath>
#include <sstream>
#include <variant>

#include "daemon/rpc_error.hpp"
#include "geometry/file_error.hpp"
#include "geometry/mesh_io.hpp"
#include "planner/model_limits.hpp"

namespace cmm::daemon {

ReferenceModel load_reference_model(const std::filesystem::path& file, const JobRequest& request,
                                    const description::TravelBox& travel_box, const geometry::CancelCheck& cancel) {
  ReferenceModel m;
  geometry::ReadResult read;
  try {
    read = geometry::read_model(file);
  } catch (const std::exception& e) {
    throw RpcError(rpc_code::model_error, e.what(), {{"file", file.string()}});
  }
  if (std::holds_alternative<geometry::PointCloud>(read.model))
    throw RpcError(rpc_code::model_error,
                   file.string() + " holds a point cloud, not a mesh: meshing a raw scan is not built yet",
                   {{"file", file.string()}});
  m.mesh = std::get<geometry::TriangleMesh>(std::move(read.model));
  if (m.mesh.faces.rows() == 0)
    throw RpcError(rpc_code::model_error, file.string() + ": no usable triangles left after dropping degenerate ones",
                   {{"file", file.string()}});
  m.mesh.vertices *= request.scale;
  if (!m.mesh.vertices.allFinite())
    throw RpcError(rpc_code::model_error, file.string() + ": scale takes coordinates beyond a double's range",
                   {{"file", file.string()}});
  const planner::ModelLimits limits;
  try {
    std::ostringstream source;
    source << file.string() << " (scale " << request.scale << ")";
    planner::check_model_limits(m.mesh, travel_box, source.str(), limits);
  } catch (const planner::ModelRefused& e) {
    throw RpcError(rpc_code::model_error, e.what(), {{"file", file.string()}, {"kind", "too_large"}});
  }
  m.inputs.model_file = file;
  m.inputs.scale = request.scale;
  m.inputs.spacing = request.spacing_mm;
  m.inputs.feature_angle_deg = request.feature_angle_deg;
  m.inputs.delta = request.delta_mm;
  m.inputs.delta_source = "job request (or cmmd.json's job.delta_mm)";
  m.inputs.read_report = read.report;
  m.inputs.vertex_count = static_cast<std::size_t>(m.mesh.vertices.rows());
  m.inputs.face_count = static_cast<std::size_t>(m.mesh.faces.rows());
  geometry::FeatureModelOptions options;
  options.spacing = request.spacing_mm;
  options.features.angle_deg = request.feature_angle_deg;
  options.max_points = limits.max_edge_points;
  options.cancel = cancel;
  try {
    m.features = geometry::extract_features(m.mesh, options);
  } catch (const geometry::Cancelled&) {
    throw;
  } catch (const geometry::TooManyPoints& e) {
    throw RpcError(rpc_code::model_error, file.string() + ": " + e.what(),
                   {{"file", file.string()}, {"kind", "too_many_points"}, {"points", e.points}, {"limit", e.limit}});
  } catch (const std::exception& e) {
    throw RpcError(rpc_code::model_error, file.string() + ": " + e.what(), {{"file", file.string()}});
  }
  return m;
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

planner::MeasurementPlan plan_job(const ReferenceModel& model, const Eigen::Isometry3d& T_M_S,
                                  const description::MachineDescription& machine, const JobRequest& request,
                                  const geometry::CancelCheck& cancel) {
  planner::MeasurementPlanOptions options;
  options.touch.radius = machine.tip().ball_radius_mm;
  options.touch.delta = request.delta_mm;
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
