// The plan JSON of DESIGN.md ("cmmd.plan/2", schema in docs/plan.schema.json): what cmm-plan writes
// and the daemon stores with each job. Vectors are [x, y, z]; angles in degrees at this edge only.
// Version 2 added the motions the machine makes (planner/touch_sequence.hpp) and each touch's
// minimum travel.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "geometry/feature_model.hpp"
#include "geometry/mesh_io.hpp"
#include "geometry/scan_front_end.hpp"
#include "planner/measurement_plan.hpp"

namespace cmm::planner {

inline constexpr const char* plan_schema_id = "cmmd.plan/2";

// Where the plan's inputs came from, recorded so a plan can be traced back and re-run.
struct PlanInputs {
  std::filesystem::path model_file;
  double scale = 1;
  double spacing = 2;
  double feature_angle_deg = 30;
  double probe_radius = 1;
  double delta = 0.2;
  std::string delta_source;
  geometry::ReadReport read_report;
  std::size_t vertex_count = 0, face_count = 0;
  std::vector<std::string> notes;
  // A raw scan: the options it was meshed with and what each stage did; empty for a mesh.
  std::optional<geometry::ScanOptions> scan_options;
  std::optional<geometry::ScanReport> scan;
};

nlohmann::json to_json(const geometry::EdgePoint& point);
nlohmann::json to_json(const geometry::Hole& hole);
nlohmann::json to_json(const Touch& touch, double clearance_z, double probe_speed_mm_s);
nlohmann::json to_json(const Motion& motion);

// What cmmd reads back of a plan it wrote (a job resumed from its folder): the program's touch ids
// in machine order and its clearance plane. nlohmann::json::exception for what is not a plan.
struct PlanSummary {
  std::vector<int> touch_ids;
  double clearance_z = 0;
};
PlanSummary plan_summary_from_json(const nlohmann::json& plan);

// Without a measurement plan the windows, approaches, program and estimate stay null or empty;
// `registration` is the registration's JSON, or null when T_M_S is assumed to be the identity.
nlohmann::json plan_json(const geometry::FeatureModel& model, const PlanInputs& inputs,
                         const MeasurementPlan* plan = nullptr, const description::MachineDescription* machine = nullptr,
                         const nlohmann::json& registration = nullptr);

}  // namespace cmm::planner
