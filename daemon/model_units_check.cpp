// The request's model and nominal against the plate, before anything moves; see model_units_check.hpp.
#include "daemon/model_units_check.hpp"

#include <sstream>
#include <variant>

#include "daemon/client/rpc_error.hpp"
#include "geometry/mesh_io.hpp"
#include "hal/description/eigen_json.hpp"
#include "planner/model_units.hpp"
#include "planner/plate_pose.hpp"

namespace cmm::daemon {

namespace {

// Where the request's corners put the plate in S; none without corners.
std::optional<Eigen::Isometry3d> plate_in_scan(const JobRequest& request) {
  std::vector<int> ids;
  std::vector<Eigen::Vector3d> scan;
  if (request.measure) {
    ids = request.measure->ids;
    scan = request.measure->scan;
  } else if (request.given) {
    for (const planner::CornerPair& c : request.given->corners) {
      ids.push_back(c.id);
      scan.push_back(c.scan);
    }
  }
  if (ids.size() < 3) return std::nullopt;
  return planner::fit_plate_pose(request.plate, ids, scan);
}

// One of the request's models (`field` "/model" or "/nominal/model"), its points in mm after
// `scale`, checked; `overridden` keeps a refusal as a note. A nominal must be a mesh: its edges are
// what the job is held to, and a cloud has none (the job would find out only at its result).
void check_model(const ModelStore& models, const std::string& ref, const std::string& field, double scale, bool overridden,
                 const description::TravelBox& travel_box, const description::Plate& plate,
                 const std::optional<Eigen::Isometry3d>& T_S_P, std::vector<std::string>& notes) {
  const bool nominal = field == "/nominal/model";
  const std::string what = nominal ? "nominal " : "";
  const std::filesystem::path file = models.resolve(ref, field);
  geometry::ReadResult read;
  try {
    read = geometry::read_model(file);
  } catch (const std::exception& e) {  // FileError names the file and the line or byte
    throw RpcError(rpc_code::model_error, what + e.what(), {{"file", file.string()}, {"kind", "unreadable"}, {"path", field}});
  }
  // A raw scan's points before any meshing, a mesh's vertices.
  geometry::PointCloud* cloud = std::get_if<geometry::PointCloud>(&read.model);
  if (cloud && nominal)
    throw_invalid_param(field, "\"" + ref + "\" is a point cloud (" + file.filename().string() +
                                   " has no faces): a nominal must be a mesh, the part as drawn (STL, OBJ, OFF or PLY with faces)");
  geometry::Points& points = cloud ? cloud->points : std::get<geometry::TriangleMesh>(read.model).vertices;
  points *= scale;
  // A model no placement fits in the travel box is the model limits' to refuse, with their message
  // naming the stray vertex (planner/model_limits.hpp), when the job or the preview loads it.
  if (points.rows() > 0 && points.allFinite() &&
      (points.colwise().maxCoeff() - points.colwise().minCoeff()).maxCoeff() > (travel_box.max - travel_box.min).cwiseMax(0).norm())
    return;
  std::ostringstream source;
  source << what << file.filename().string() << " (scale " << scale << ")";
  const planner::ModelUnits u = planner::check_model_units(points, scale, source.str(), plate, T_S_P);
  for (const std::string& n : u.notes) notes.push_back(what.empty() ? n : what + "(" + n + ")");
  if (u.problem.empty()) return;
  if (overridden) {
    notes.push_back("the unit check is overridden (units_checked or an explicit scale); it found: " + u.problem);
    return;
  }
  nlohmann::json data = {{"file", file.string()},
                         {"kind", u.factor ? "units" : "off_plate"},
                         {"extent_mm", description::vec3_json(u.extent_mm)},
                         {"nominal", nominal}};
  if (u.factor) data.update({{"factor", *u.factor}, {"scale", scale * *u.factor}});
  throw RpcError(rpc_code::model_error, u.problem, data);
}

}  // namespace

std::vector<std::string> check_request_units(const JobRequest& request, const ModelStore& models,
                                             const description::TravelBox& travel_box) {
  std::vector<std::string> notes;
  const std::optional<Eigen::Isometry3d> T_S_P = plate_in_scan(request);
  check_model(models, request.model, "/model", request.scale, request.units_checked || request.scale_given, travel_box,
              request.plate, T_S_P, notes);
  if (request.nominal) {
    // A nominal fitted onto the scan may stand anywhere in its file: only its size is checked then.
    const bool given = request.nominal->placement == "given";
    check_model(models, request.nominal->model, "/nominal/model", request.nominal->scale,
                request.units_checked || request.nominal->scale_given, travel_box, request.plate,
                given ? T_S_P : std::nullopt, notes);
  }
  return notes;
}

}  // namespace cmm::daemon
