// cmm-plan: offline planning from a mesh, no machine. Reads the model, extracts reference edge points
// and holes, writes the plan JSON and prints a summary an operator can read at a glance.
#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "geometry/feature_model.hpp"
#include "geometry/file_error.hpp"
#include "geometry/mesh_io.hpp"
#include "planner/plan_json.hpp"

namespace {

using namespace cmm;

int plan(const std::string& model_path, const std::string& output, planner::PlanInputs inputs) {
  geometry::ReadResult read = geometry::read_model(model_path);
  if (const auto* cloud = std::get_if<geometry::PointCloud>(&read.model)) {
    std::cerr << "cmm-plan: " << model_path << " holds a point cloud (" << cloud->points.rows()
              << " points, no faces).\n  Meshing a raw scan (thinning and triangulation, thesis Ch. 3-4) is not"
                 " built yet: give a triangle mesh (STL, PLY, OBJ or OFF).\n";
    return 2;
  }
  geometry::TriangleMesh mesh = std::get<geometry::TriangleMesh>(std::move(read.model));
  if (mesh.faces.rows() == 0) {
    std::cerr << "cmm-plan: " << model_path << ": no usable triangles left after dropping degenerate ones\n";
    return 2;
  }
  mesh.vertices *= inputs.scale;
  if (!mesh.vertices.allFinite()) {
    std::cerr << "cmm-plan: " << model_path << ": --scale " << inputs.scale
              << " takes coordinates beyond the range of a double\n";
    return 2;
  }
  inputs.model_file = model_path;
  inputs.read_report = read.report;
  inputs.vertex_count = static_cast<std::size_t>(mesh.vertices.rows());
  inputs.face_count = static_cast<std::size_t>(mesh.faces.rows());

  geometry::FeatureModelOptions options;
  options.spacing = inputs.spacing;
  options.features.angle_deg = inputs.feature_angle_deg;
  const geometry::FeatureModel model = geometry::extract_features(mesh, options);

  inputs.notes.push_back("no registration given: T_M_S is taken as identity (the plan is in the scan frame S)");
  inputs.notes.push_back("probe windows, approaches and the move program are not computed yet (planner issue)");
  const nlohmann::json plan = planner::plan_json(model, inputs);
  // Written beside the target and renamed over it, so a failed write never leaves half a plan.
  const std::string partial = output + ".partial";
  {
    std::ofstream out(partial);
    out << plan.dump(1) << '\n';
    out.close();
    std::error_code renamed;
    if (out) std::filesystem::rename(partial, output, renamed);
    if (!out || renamed) {
      std::error_code ignored;
      std::filesystem::remove(partial, ignored);
      std::cerr << "cmm-plan: cannot write " << output << ": " << (renamed ? renamed.message() : std::strerror(errno))
                << '\n';
      return 1;
    }
  }

  const auto& t = model.topology;
  std::size_t sharp = 0, rim = 0, boundary = 0, convex = 0;
  for (const auto& p : model.points) {
    (p.kind == geometry::EdgeKind::sharp_edge ? sharp : p.kind == geometry::EdgeKind::hole_rim ? rim : boundary)++;
    convex += p.convex && p.kind != geometry::EdgeKind::boundary;
  }
  std::printf("model      %s: %zu vertices, %zu triangles (scale %g)\n", model_path.c_str(), inputs.vertex_count,
              inputs.face_count, inputs.scale);
  std::printf("read       %zu vertices welded, %zu degenerate and %zu duplicate faces dropped\n",
              read.report.vertices_welded, read.report.degenerate_faces_dropped, read.report.duplicate_faces_dropped);
  std::printf("topology   %d component(s), %s, %zu boundary edges in %zu loops, %zu non-manifold edges%s\n",
              t.components, t.closed() ? "closed" : "open", t.boundary_edges, model.loops.size(), t.non_manifold_edges,
              t.inconsistently_oriented_edges ? ", ORIENTATION INCONSISTENT" : "");
  std::printf("surface    median dihedral %.2f deg -> %s\n", model.features.median_dihedral_deg,
              model.features.noisy ? "noisy: normals filtered before feature detection" : "clean");
  std::printf("features   %zu sharp curves over %g deg\n", model.features.curves.size(), inputs.feature_angle_deg);
  std::printf("points     %zu reference edge points every %g: %zu sharp edge, %zu hole rim, %zu open boundary; %zu convex\n",
              model.points.size(), inputs.spacing, sharp, rim, boundary, convex);
  std::size_t bores = 0;
  for (const auto& h : model.holes) bores += h.source == geometry::HoleSource::bore;
  std::printf("holes      %zu hole(s): %zu bore(s) with their wall, %zu open rim(s) whose wall the mesh lacks\n",
              model.holes.size(), bores, model.holes.size() - bores);
  for (const auto& h : model.holes) {
    char depth[32] = "n/a (no wall)";
    if (h.depth) std::snprintf(depth, sizeof depth, "%.3f", *h.depth);
    std::printf("hole %-3d   %-13s centre (%.3f, %.3f, %.3f)  diameter %.3f  depth %s  roundness %.4f\n", h.id,
                geometry::to_string(h.source), h.centre.x(), h.centre.y(), h.centre.z(), 2 * h.radius, depth,
                h.roundness_mm);
  }
  std::printf("plan       written to %s (T_M_S = identity: no registration given)\n", output.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cmm-plan: plan the CMM re-measurement of a scanned part's edges and holes (no machine)"};
  std::string model_path, output;
  planner::PlanInputs inputs;
  app.add_option("MODEL", model_path, "reference mesh: STL, PLY, OBJ or OFF")->required()->check(CLI::ExistingFile);
  app.add_option("-o,--output", output, "plan JSON to write")->required();
  app.add_option("--scale", inputs.scale, "multiply coordinates by this (unitless models to mm)")
      ->check(CLI::PositiveNumber);
  app.add_option("--spacing", inputs.spacing, "distance between reference edge points, mm")
      ->check(CLI::PositiveNumber);
  app.add_option("--feature-angle", inputs.feature_angle_deg, "dihedral angle above which an edge is sharp, degrees")
      ->check(CLI::Range(1.0, 179.0));
  app.add_option("--probe-radius", inputs.probe_radius, "stylus ball radius r, mm")->check(CLI::PositiveNumber);
  app.add_option("--delta", inputs.delta, "bound on the reference points' error, mm")->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  inputs.delta_source = app.count("--delta") ? "given with --delta" : "default: laser scanner noise bound (thesis Ch. 5)";
  try {
    return plan(model_path, output, inputs);
  } catch (const cmm::geometry::FileError& error) {
    std::cerr << "cmm-plan: " << error.what() << '\n';
    return 2;
  } catch (const std::exception& error) {  // out of memory and the like: say so, no core dump
    std::cerr << "cmm-plan: " << model_path << ": " << error.what() << '\n';
    return 1;
  }
}
