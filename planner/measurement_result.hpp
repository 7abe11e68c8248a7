// What one job measured: every planned edge point and bore, compensated, in both frames, with its
// deviation from the reference model, or the reason it has none; docs/result.md is the layout.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/edge_point.hpp"
#include "planner/bore_measurement.hpp"
#include "planner/edge_compensation.hpp"
#include "planner/inspection.hpp"
#include "planner/touch_planning.hpp"

namespace cmm::planner {

enum class FeatureStatus {
  measured,     // compensated; positions, deviation and uncertainty are set
  failed,       // planned, but a touch is missing or missed, or compensation refused it: `reason`
  not_planned,  // the plan could not measure it (no window, out of reach, open rim): the plan's reason
};

const char* to_string(FeatureStatus status);

struct EdgeResult {
  int id = -1;  // the model's edge point id
  geometry::EdgeKind kind = geometry::EdgeKind::sharp_edge;
  EdgeMethod method = EdgeMethod::none;  // as planned
  FeatureStatus status = FeatureStatus::not_planned;
  std::string reason;         // failed / not_planned: why; measured: the plan's note (e.g. why faces)
  std::vector<int> touch_ids;  // the plan's touches this point was measured with
  std::string tip;             // the tip that made them
  Vec3 reference = Vec3::Zero();  // the reference point, S
  // Set when measured: the same point in M (as compensated) and in S (through T_M_S⁻¹).
  std::optional<MeasuredPoint> machine, scan;
  EdgeDeviation deviation;  // in S, against `reference` (signed_deviation's sign convention)
};

struct HoleResult {
  int id = -1;  // the model's hole id
  FeatureStatus status = FeatureStatus::not_planned;
  std::string reason;
  std::vector<int> touch_ids;
  std::string tip;  // the tip that made them
  double depth_mm = 0;                // planned touch depth below the entry rim
  Vec3 nominal_centre = Vec3::Zero(); // the model's entry-rim centre, S
  Vec3 nominal_axis = Vec3::UnitZ();  // unit, S, out of the material
  double nominal_diameter_mm = 0;
  std::optional<BoreMeasurement> machine, scan;
  // Measured centre minus the model's axis line (the part across the axis, S): one depth fixes no
  // position along the axis, so only the offset across it is a deviation.
  Vec3 centre_offset = Vec3::Zero();
  double centre_deviation_mm = 0;    // |centre_offset|
  double diameter_deviation_mm = 0;  // measured − nominal diameter: positive, the bore is larger
  std::vector<MeasuredPoint> wall_points;  // the touched wall points, S (for the merged cloud)
};

struct ResultSummary {
  int edge_points = 0, edges_measured = 0, edges_failed = 0, edges_not_planned = 0;
  int holes = 0, holes_measured = 0, holes_failed = 0, holes_not_planned = 0;
  double rms_deviation_mm = 0;   // over the measured edge points' |signed deviation|
  double max_deviation_mm = 0;   // largest |signed deviation|
  int max_deviation_id = -1;     // which edge point that is
  double worst_sigma_mm = 0;     // largest 1-σ of a measured edge point
  int worst_sigma_id = -1;
  double max_centre_deviation_mm = 0;    // over measured holes
  double max_diameter_deviation_mm = 0;  // largest |diameter deviation|
};

struct MeasurementResult {
  Eigen::Isometry3d T_M_S = Eigen::Isometry3d::Identity();  // the registration the touches were compensated with
  double ball_radius_mm = 0;
  double trigger_sigma_mm = 0;
  std::vector<EdgeResult> edges;  // one per model edge point, in the model's order
  std::vector<HoleResult> holes;  // one per model hole
  ResultSummary summary;
  std::vector<std::string> notes;  // job-wide: touches that belong to no feature, assumptions
  // Against the job's nominal model, with tolerances and verdicts; absent when it named none (the
  // deviations above are against the scan, the job's reference, and carry no verdict).
  std::optional<InspectionResult> inspection;
};

ResultSummary summarise(const std::vector<EdgeResult>& edges, const std::vector<HoleResult>& holes);

// Every measured point in S: the edge points, then the bores' wall points (write_merged_ply's input).
std::vector<MeasuredPoint> measured_points_in_scan(const MeasurementResult& result);

}  // namespace cmm::planner
