// Serialises the feature model and the measurement plan into the plan JSON.
#include "planner/plan_json.hpp"

#include <cmath>
#include <numbers>

#include "hal/description/eigen_json.hpp"

namespace cmm::planner {
namespace {

using description::vec3_json;
using nlohmann::json;

double degrees(double radians) { return radians * 180.0 / std::numbers::pi; }

json window_json(const ProbeWindow& w) {
  return {{"axis", vec3_json(w.axis)},
          {"half_angle_deg", degrees(w.half_angle_rad)},
          {"plane_normal", vec3_json(w.plane_normal)},
          {"margin_deg", degrees(w.margin_rad)},
          {"margin_up_deg", degrees(w.margin_up_rad)},
          {"margin_down_deg", degrees(w.margin_down_rad)},
          {"bisector", vec3_json(w.bisector)},
          {"exact_half_angle_deg", degrees(w.exact_half_angle_rad)}};
}

json touch_ids(const std::vector<Touch>& touches) {
  json ids = json::array();
  for (const Touch& t : touches) ids.push_back(t.id);
  return ids;
}

void add_edge_plan(json& point, const EdgePlan& plan) {
  point["method"] = to_string(plan.method);
  point["probeable"] = plan.method != EdgeMethod::none;
  point["reason"] = plan.reason.empty() ? json(nullptr) : json(plan.reason);
  point["window"] = plan.window ? window_json(*plan.window) : json(nullptr);
  if (plan.method == EdgeMethod::two_touch) {
    point["approach"] = {vec3_json(plan.touches[0].direction), vec3_json(plan.touches[1].direction)};
    point["beta_deg"] = {degrees(plan.beta_rad[0]), degrees(plan.beta_rad[1])};
  }
  point["touches"] = touch_ids(plan.touches);
  point["tip"] = plan.method != EdgeMethod::none ? json(plan.tip) : json(nullptr);
}

void add_bore_plan(json& hole, const BorePlan& plan) {
  hole["bore"] = plan.planned ? json{{"depth_mm", plan.depth_mm}, {"touches", touch_ids(plan.touches)}} : json(nullptr);
  hole["bore_reason"] = plan.planned ? json(nullptr) : json(plan.reason);
  hole["tip"] = plan.planned ? json(plan.tip) : json(nullptr);
}

}  // namespace

json to_json(const Touch& t, double clearance_z, double probe_speed_mm_s) {
  json j = {{"id", t.id},
            {"target", to_string(t.target)},
            {"face", t.face},
            {"surface_point", vec3_json(t.surface_point)},
            {"direction", vec3_json(t.direction)},
            {"nominal_centre", vec3_json(t.nominal_centre)},
            {"above", vec3_json(geometry::Vec3(t.start.x(), t.start.y(), clearance_z))},
            {"start", vec3_json(t.start)},
            {"max_travel_mm", t.max_travel_mm},
            {"speed_mm_s", probe_speed_mm_s},
            {"min_travel_mm", t.min_travel_mm},
            {"retract_mm", t.retract_mm}};
  if (t.edge_point >= 0) j["edge_point"] = t.edge_point;
  if (t.hole >= 0) j["hole"] = t.hole;
  if (t.corner >= 0) j["corner"] = t.corner;
  if (!t.tip.empty()) j["tip"] = t.tip;
  return j;
}

json to_json(const Motion& m) {
  json j = {{"kind", to_string(m.kind)}, {"touch", m.touch},          {"from", vec3_json(m.from)},
            {"to", vec3_json(m.to)},     {"speed_mm_s", m.speed_mm_s}, {"time_s", m.time_s}};
  if (m.kind == MotionKind::probe) {
    j["direction"] = vec3_json(m.direction);
    j["max_travel_mm"] = m.max_travel_mm;
    j["min_travel_mm"] = m.min_travel_mm;
    j["retract_mm"] = m.retract_mm;
  }
  if (m.kind == MotionKind::change_tip) j["tip"] = m.tip;
  return j;
}

json to_json(const geometry::EdgePoint& p) {
  return {
      {"id", p.id},
      {"kind", geometry::to_string(p.kind)},
      {"convex", p.convex},
      {"position", vec3_json(p.position)},
      {"n_up", vec3_json(p.n_up)},
      {"n_down", p.n_down ? vec3_json(*p.n_down) : json(nullptr)},
      {"tangent", vec3_json(p.tangent)},
      {"normals_inferred", p.normals_inferred},
      {"interior_angle_deg", p.interior_angle_rad ? json(degrees(*p.interior_angle_rad)) : json(nullptr)},
      {"normal_uncertainty_deg", {degrees(p.n_up_uncertainty_rad), degrees(p.n_down_uncertainty_rad)}},
      {"facet_spread_deg", {degrees(p.n_up_spread_rad), degrees(p.n_down_spread_rad)}},
      {"mesh_deviation_mm", p.mesh_deviation_mm},
      {"position_sigma_mm", p.position_sigma_mm},
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
      {"centre", vec3_json(h.centre)},
      {"axis", vec3_json(h.axis)},
      {"radius", h.radius},
      {"perimeter", h.perimeter},
      {"roundness_mm", h.roundness_mm},
      {"depth", h.depth ? json(*h.depth) : json(nullptr)},
      {"rim_point_ids", h.rim_point_ids},
      {"bore", nullptr},
  };
}

PlanSummary plan_summary_from_json(const json& plan) {
  PlanSummary summary;
  for (const json& t : plan.at("program")) summary.touch_ids.push_back(t.at("id").get<int>());
  summary.clearance_z = plan.at("clearance_z").get<double>();
  return summary;
}

namespace {

// How a raw scan became the mesh: the options and every stage's figures (null for a mesh).
json scan_json(const PlanInputs& inputs) {
  if (!inputs.scan || !inputs.scan_options) return nullptr;
  const geometry::ScanReport& r = *inputs.scan;
  const geometry::ScanOptions& o = *inputs.scan_options;
  json times = json::object();
  for (const geometry::ScanStageTime& t : r.times) times[t.stage] = t.seconds;
  return {{"tolerance_mm", o.tolerance_mm},
          {"bin_size_given_mm", o.bin_size_mm ? json(*o.bin_size_mm) : json(nullptr)},
          {"adaptive", o.adaptive},
          {"neighbours", o.neighbours},
          {"points_in", r.points_in},
          {"outliers_removed", r.outliers_removed},
          {"noise_sigma_mm", r.noise_sigma_mm},
          {"bin_size_mm", r.bin_size_mm},
          {"bin_size_source", r.bin_size_source},
          {"points_kept", r.points_kept},
          {"points_sparse", r.points_sparse},
          {"triangles", r.triangles},
          {"components", r.components},
          {"outer_loops", r.outer_loops},
          {"hole_loops", r.hole_loops},
          {"creases", r.creases},
          {"crease_points", r.crease_points},
          {"stage_seconds", times}};
}

double max_mesh_deviation(const geometry::FeatureModel& model) {
  double most = 0;
  for (const auto& p : model.points) most = std::max(most, p.mesh_deviation_mm);
  return most;
}

}  // namespace

json plan_json(const geometry::FeatureModel& model, const PlanInputs& inputs, const MeasurementPlan* plan,
               const description::MachineDescription* machine, const json& registration) {
  const auto& t = model.topology;
  const auto& r = inputs.read_report;
  json out = {
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
        {"scan", scan_json(inputs)},
        {"noise",
         {{"sigma_mm", model.features.noise.sigma_mm},
          {"vertices_measured", model.features.noise.measured},
          {"vertices_sampled", model.features.noise.sampled},
          {"treated_as_noisy", model.features.noisy},
          {"mesh_deviation_max_mm", max_mesh_deviation(model)}}}}},
      {"spacing", inputs.spacing},
      {"feature_angle_deg", inputs.feature_angle_deg},
      {"probe_radius", inputs.probe_radius},
      {"delta", inputs.delta},
      {"delta_source", inputs.delta_source},
      {"registration", registration},
      {"edge_points", json::array()},
      {"holes", json::array()},
      {"program", json::array()},
      {"motions", json::array()},
      {"estimate", nullptr},
      {"notes", inputs.notes},
  };
  for (const auto& p : model.points) {
    json point = to_json(p);
    point["delta"] = geometry::delta_at(p, inputs.delta);  // what its window and search were made for
    out["edge_points"].push_back(std::move(point));
  }
  for (const auto& h : model.holes) out["holes"].push_back(to_json(h));
  if (!plan || !machine) return out;
  for (std::size_t i = 0; i < plan->edges.size(); ++i) add_edge_plan(out["edge_points"][i], plan->edges[i]);
  for (std::size_t i = 0; i < plan->bores.size(); ++i) add_bore_plan(out["holes"][i], plan->bores[i]);
  out["machine"] = to_json(*machine);
  out["clearance_z"] = plan->clearance_z;
  out["floor_z"] = plan->floor_z;
  out["home"] = vec3_json(plan->program.home);
  for (const Touch& t : plan->program.touches)
    out["program"].push_back(to_json(t, plan->clearance_z, machine->probe_speed_mm_s));
  for (const Motion& m : plan->program.motions) out["motions"].push_back(to_json(m));
  out["estimate"] = {{"time_s", plan->program.time_s}, {"lower_bound_s", plan->program.lower_bound_s},
                     {"touches", plan->program.touches.size()}};
  for (const std::string& note : plan->notes) out["notes"].push_back(note);
  return out;
}

}  // namespace cmm::planner
