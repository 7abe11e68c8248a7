// The nominal read, placed and compared; see job_inspection.hpp.
#include "daemon/job_inspection.hpp"

#include <spdlog/spdlog.h>

#include <cmath>

#include "daemon/client/rpc_error.hpp"
#include "geometry/file_error.hpp"
#include "geometry/mesh_io.hpp"
#include "geometry/point_to_plane_icp.hpp"
#include "planner/inspect.hpp"
#include "planner/nominal_model.hpp"

namespace cmm::daemon {

namespace {

RpcError nominal_error(const std::string& model, const std::string& what) {
  return RpcError(rpc_code::model_error, "nominal " + model + ": " + what, {{"model", model}, {"kind", "nominal"}});
}

// A fit starts from the nominal shifted onto the reference's centre: CAD and scan usually share their
// orientation roughly (the part lies on its plate the way it was drawn), rarely their origin.
Eigen::Isometry3d centred_start(const geometry::TriangleMesh& nominal, const geometry::TriangleMesh& reference) {
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  start.translation() = reference.vertices.colwise().mean().transpose() - nominal.vertices.colwise().mean().transpose();
  return start;
}

// How far apart the two meshes' bounding boxes are (0 when they overlap).
double box_gap_mm(const geometry::TriangleMesh& a, const geometry::TriangleMesh& b) {
  const Eigen::RowVector3d gap = (b.vertices.colwise().minCoeff() - a.vertices.colwise().maxCoeff())
                                     .cwiseMax(a.vertices.colwise().minCoeff() - b.vertices.colwise().maxCoeff())
                                     .cwiseMax(0.0);
  return gap.norm();
}

}  // namespace

std::optional<planner::InspectionResult> inspect_job(const JobRequest& request, const ModelStore& models,
                                                     const ReferenceModel& reference, const planner::MeasurementResult& result) {
  if (!request.nominal) return std::nullopt;
  const NominalRequest& n = *request.nominal;
  geometry::TriangleMesh mesh;
  try {
    mesh = geometry::read_mesh(models.resolve(n.model, "/nominal/model"));
  } catch (const geometry::FileError& e) {
    throw nominal_error(n.model, e.what());
  }
  mesh.vertices *= n.scale;

  planner::NominalPlacement placement;
  placement.model = n.model;
  placement.method = n.placement == "fit" ? "icp" : "given";
  if (n.placement == "fit") {
    geometry::IcpResult fit;
    try {
      fit = geometry::point_to_plane_icp(mesh, reference.mesh, centred_start(mesh, reference.mesh));
    } catch (const std::invalid_argument& e) {
      throw nominal_error(n.model, e.what());
    }
    if (!fit.converged)
      throw nominal_error(n.model, "the point-to-plane fit onto the reference did not converge in " +
                                       std::to_string(fit.iterations) + " iterations (RMS " + std::to_string(fit.rms_mm) +
                                       " mm): give the nominal in the reference's frame, or closer to it");
    placement.T_S_N = fit.T_target_source;
    placement.iterations = fit.iterations;
    placement.converged = fit.converged;
    placement.rms_mm = fit.rms_mm;
    placement.overlap = fit.overlap;
    spdlog::info("nominal {}: fitted onto the reference in {} iterations, RMS {:.4f} mm, overlap {:.2f}", n.model,
                 fit.iterations, fit.rms_mm, fit.overlap);
  }
  if (n.placement == "given") {
    // A nominal given in another frame (the CAD origin, a scale of 1000) would only say "no nominal
    // edge near" for every point: say what is wrong instead.
    const double gap = box_gap_mm(mesh, reference.mesh);
    if (gap > 10)
      throw nominal_error(n.model, "lies " + std::to_string(static_cast<long long>(std::lround(gap))) +
                                       " mm from the reference: it is not in the reference's frame (check its scale, "
                                       "or ask for \"placement\": \"fit\")");
  }
  const planner::NominalModel nominal = planner::nominal_model(mesh, placement.T_S_N, request.feature_angle_deg);
  return planner::inspect(result, reference.features.points, nominal, request.tolerances, placement, request.inspect);
}

}  // namespace cmm::daemon
