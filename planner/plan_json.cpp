// Serialises the feature model into the plan JSON; windows, approaches, registration and the move
// program stay null until the planner computes them.
#include "planner/plan_json.hpp"

#include <cmath>
#include <numbers>

namespace cmm::planner {
namespace {

using nlohmann::json;

json vec(const geometry::Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }
double degrees(double radians) { return radians * 180.0 / std::numbers::pi; }

}  // namespace

json to_json(const geometry::EdgePoint& p) {
  return {
      {"id", p.id},
      {"kind", geometry::to_string(p.kind)},
      {"convex", p.convex},
      {"position", vec(p.position)},
      {"n_up", vec(p.n_up)},
      {"n_down", p.n_down ? vec(*p.n_down) : json(nullptr)},
      {"tangent", vec(p.tangent)},
      {"normals_inferred", p.normals_inferred},
      {"interior_angle_deg", p.interior_angle_rad ? json(degrees(*p.interior_angle_rad)) : json(nullptr)},
      {"normal_uncertainty_deg", {degrees(p.n_up_uncertainty_rad), degrees(p.n_down_uncertainty_rad)}},
      {"facet_spread_deg", {degrees(p.n_up_spread_rad), degrees(p.n_down_spread_rad)}},
      {"probeable", p.probeable},
      {"reason", p.reason.empty() ? json(nullptr) : json(p.reason)},
      {"curve", p.curve},
      {"hole", p.hole >= 0 ? json(p.hole) : json(nullptr)},
      {"window", nullptr},
      {"approach", nullptr},
  };
}

json to_json(const geometry::Hole& h) {
  return {
      {"id", h.id},
      {"source", geometry::to_string(h.source)},
      {"centre", vec(h.centre)},
      {"axis", vec(h.axis)},
      {"radius", h.radius},
      {"perimeter", h.perimeter},
      {"roundness_mm", h.roundness_mm},
      {"depth", h.depth ? json(*h.depth) : json(nullptr)},
      {"rim_point_ids", h.rim_point_ids},
      {"bore", nullptr},
  };
}

json plan_json(const geometry::FeatureModel& model, const PlanInputs& inputs) {
  const auto& t = model.topology;
  const auto& r = inputs.read_report;
  json plan = {
      {"schema", plan_schema_id},
      {"frame", "S"},
      {"model",
       {{"file", inputs.model_file.string()},
        {"scale", inputs.scale},
        {"vertices", inputs.vertex_count},
        {"faces", inputs.face_count},
        {"read",
         {{"vertices_welded", r.vertices_welded},
          {"degenerate_faces_dropped", r.degenerate_faces_dropped},
          {"duplicate_faces_dropped", r.duplicate_faces_dropped},
          {"polygons_triangulated", r.polygons_triangulated}}},
        {"topology",
         {{"components", t.components},
          {"boundary_edges", t.boundary_edges},
          {"non_manifold_edges", t.non_manifold_edges},
          {"inconsistently_oriented_edges", t.inconsistently_oriented_edges},
          {"euler_characteristic", t.euler_characteristic},
          {"boundary_loops", model.loops.size()}}},
        {"noise",
         {{"median_dihedral_deg", model.features.median_dihedral_deg},
          {"treated_as_noisy", model.features.noisy},
          {"mean_edge_length", model.features.mean_edge_length}}}}},
      {"spacing", inputs.spacing},
      {"feature_angle_deg", inputs.feature_angle_deg},
      {"probe_radius", inputs.probe_radius},
      {"delta", inputs.delta},
      {"delta_source", inputs.delta_source},
      {"registration", nullptr},
      {"edge_points", json::array()},
      {"holes", json::array()},
      {"program", json::array()},
      {"estimate", nullptr},
      {"notes", inputs.notes},
  };
  for (const auto& p : model.points) plan["edge_points"].push_back(to_json(p));
  for (const auto& h : model.holes) plan["holes"].push_back(to_json(h));
  return plan;
}

}  // namespace cmm::planner
