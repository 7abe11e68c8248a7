// The reference model a plan is made on, from a model file: read, scaled to mm, held against the
// model limits, and its features extracted. The one loader cmm-plan and cmmd share, and so the place
// where the scan front end (a raw cloud thinned and triangulated, thesis Ch. 3-4) plugs in.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>

#include "geometry/cancellation.hpp"
#include "geometry/feature_model.hpp"
#include "geometry/scan_front_end.hpp"
#include "hal/description/machine_description.hpp"
#include "planner/model_limits.hpp"
#include "planner/plan_json.hpp"

namespace cmm::planner {

struct ReferenceModel {
  geometry::TriangleMesh mesh;  // S, mm
  geometry::FeatureModel features;
  PlanInputs inputs;  // what the plan JSON records of its inputs: file, scale, spacing, angle, read report
  // When the file was a raw scan: how it was thinned and triangulated into `mesh`. A job stores
  // `mesh` in its folder and a resumed job plans on that, never re-meshing the scan.
  std::optional<geometry::ScanReport> scan;
};

struct ReferenceModelOptions {
  double scale = 1;  // model units to mm
  double spacing = 2;
  double feature_angle_deg = 30;
  ModelLimits limits;
  geometry::CancelCheck cancel;  // polled between the steps of feature extraction
  // For a raw scan (a file of points without faces): tolerance, bin size, adaptive bins. The scan's
  // coordinates are scaled first, so the tolerance and bin size are in mm.
  geometry::ScanOptions scan;
  // The mesh file is one the scan front end made (a job's stored reference.ply): its features are
  // taken as from the scan itself, whatever its vertex scatter (FeatureOptions::made_from_scan).
  bool made_from_scan = false;
};

// Why a model file gives no reference model; what() names the file and, where its reader knows it,
// the line or byte.
class ModelError : public std::runtime_error {
 public:
  enum class Kind {
    unreadable,       // the reader refused the file
    scan,             // a raw scan (points without faces) the front end could not mesh
    empty,            // no triangles left after the degenerate ones were dropped
    out_of_range,     // the scale takes coordinates beyond a double's range
    too_large,        // planner::check_model_limits refused it
    too_many_points,  // its feature curves would give more reference points than the limit
    features,         // feature extraction failed for another reason
  };
  ModelError(Kind kind, std::filesystem::path file, const std::string& message, std::size_t points = 0,
             std::size_t limit = 0)
      : std::runtime_error(message), kind(kind), file(std::move(file)), points(points), limit(limit) {}
  Kind kind;
  std::filesystem::path file;
  std::size_t points = 0, limit = 0;  // too_many_points only
};
const char* to_string(ModelError::Kind kind);  // "unreadable", "scan", …

// Throws ModelError, or geometry::Cancelled when options.cancel asks. `travel_box` is the machine's,
// for the model limits (a size check: the frames differ before registration).
ReferenceModel load_reference_model(const std::filesystem::path& file, const description::TravelBox& travel_box,
                                    const ReferenceModelOptions& options = {});

// The δ a plan on this model is made for: the given bound on the reference's error (from `source`),
// raised to 3 standard errors of a reference point from the vertex noise the mesh shows
// (FeatureModel::point_sigma_mm) when that is larger, and said so in delta_source.
// Each edge point's own δ is geometry::delta_at: its position's 3 standard errors where more, and its
// mesh deviation on top.
void settle_delta(PlanInputs& inputs, double given, const std::string& source, const geometry::FeatureModel& model);

}  // namespace cmm::planner
