// Model file to reference model; see reference_model.hpp.
#include "planner/reference_model.hpp"

#include <algorithm>
#include <sstream>
#include <variant>

#include "geometry/mesh_io.hpp"
#include "planner/number_text.hpp"

namespace cmm::planner {

const char* to_string(ModelError::Kind kind) {
  switch (kind) {
    case ModelError::Kind::unreadable: return "unreadable";
    case ModelError::Kind::scan: return "scan";
    case ModelError::Kind::empty: return "empty";
    case ModelError::Kind::out_of_range: return "out_of_range";
    case ModelError::Kind::too_large: return "too_large";
    case ModelError::Kind::too_many_points: return "too_many_points";
    case ModelError::Kind::features: return "features";
  }
  return "?";
}

ReferenceModel load_reference_model(const std::filesystem::path& file, const description::TravelBox& travel_box,
                                    const ReferenceModelOptions& options) {
  using Kind = ModelError::Kind;
  const std::string name = file.string();
  geometry::ReadResult read;
  try {
    read = geometry::read_model(file);
  } catch (const std::exception& e) {  // FileError names the file and the line or byte
    throw ModelError(Kind::unreadable, file, e.what());
  }
  ReferenceModel m;
  if (auto* cloud = std::get_if<geometry::PointCloud>(&read.model)) {
    // A raw scan: scaled to mm first, so that the tolerance and the bin size are in mm.
    cloud->points *= options.scale;
    geometry::ScanOptions scan = options.scan;
    scan.max_points = std::min(scan.max_points, options.limits.max_scan_points);
    scan.cancel = options.cancel;
    geometry::ScanMesh meshed;
    try {
      meshed = geometry::mesh_scan(*cloud, name, scan);
    } catch (const geometry::ScanError& e) {
      throw ModelError(Kind::scan, file, e.what());
    }
    m.mesh = std::move(meshed.mesh);
    m.scan = meshed.report;
    m.inputs.scan = meshed.report;
    m.inputs.scan_options = scan;
  } else {
    m.mesh = std::get<geometry::TriangleMesh>(std::move(read.model));
    if (m.mesh.faces.rows() == 0)
      throw ModelError(Kind::empty, file, name + ": no usable triangles left after dropping degenerate ones");
    m.mesh.vertices *= options.scale;
  }
  std::ostringstream source;
  source << name << " (scale " << options.scale << ")";
  if (!m.mesh.vertices.allFinite())
    throw ModelError(Kind::out_of_range, file, source.str() + ": the scale takes coordinates beyond the range of a double");
  try {
    check_model_limits(m.mesh, travel_box, source.str(), options.limits);
  } catch (const ModelRefused& e) {
    throw ModelError(Kind::too_large, file, e.what());
  }

  PlanInputs& in = m.inputs;
  in.model_file = file;
  in.scale = options.scale;
  in.spacing = options.spacing;
  in.feature_angle_deg = options.feature_angle_deg;
  in.read_report = read.report;
  in.vertex_count = static_cast<std::size_t>(m.mesh.vertices.rows());
  in.face_count = static_cast<std::size_t>(m.mesh.faces.rows());
  geometry::FeatureModelOptions features;
  features.spacing = options.spacing;
  features.features.angle_deg = options.feature_angle_deg;
  features.features.made_from_scan = m.scan.has_value() || options.made_from_scan;
  features.max_points = options.limits.max_edge_points;
  features.cancel = options.cancel;
  try {
    m.features = geometry::extract_features(m.mesh, features);
  } catch (const geometry::Cancelled&) {
    throw;
  } catch (const geometry::TooManyPoints& e) {
    throw ModelError(Kind::too_many_points, file, name + ": " + e.what(), e.points, e.limit);
  } catch (const std::exception& e) {
    throw ModelError(Kind::features, file, name + ": " + e.what());
  }
  return m;
}

void settle_delta(PlanInputs& inputs, double given, const std::string& source, const geometry::FeatureModel& model) {
  const double sigma = model.features.noise.sigma_mm, point = model.point_sigma_mm;
  inputs.delta = std::max(given, 3 * point);
  inputs.delta_source = source + "; the mesh's vertex noise sigma " + fixed(sigma * 1e3, 1) + " um on " +
                        std::to_string(model.features.noise.measured) + " vertices, " + fixed(point * 1e3, 1) +
                        " um on a typical reference point" + (3 * point > given ? ", so delta is raised to 3 of those" : ", within it") +
                        (inputs.scan ? "; the raw scan's own noise sigma " + fixed(inputs.scan->noise_sigma_mm * 1e3, 1) +
                                           " um (its local fits' residuals)"
                                     : std::string()) +
                        "; a point smoothed less raises its own to 3 of its position_sigma_mm, and each adds the mesh's own "
                        "distance from its edge (mesh_deviation_mm)";
}

}  // namespace cmm::planner
