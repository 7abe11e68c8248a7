// The gate a reference model passes before any work that grows with it (features, touches,
// previews): one that no placement could fit in the machine's travel box (a stray vertex kilometres
// away, a model in the wrong unit) or that is larger than the documented counts is refused here.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

#include "geometry/mesh.hpp"
#include "hal/description/machine_description.hpp"

namespace cmm::planner {

// The documented limits (README, docs/api.md). A 5,000,000-face mesh plans in about 20 s in about
// 0.8 GB; 20,000 reference points are 5 to 10 hours of touches.
struct ModelLimits {
  std::size_t max_vertices = 5'000'000;
  std::size_t max_faces = 5'000'000;
  std::size_t max_edge_points = 20'000;  // for geometry::FeatureModelOptions::max_points
  // A raw scan's points before thinning: the front end holds a local fit per point (about 300 bytes
  // with its index), so 10,000,000 points peak near 3 GB; a larger scan should be thinned first.
  std::size_t max_scan_points = 10'000'000;
};

// Refused: what() says why, naming the file and, for a size, the vertex farthest from the rest.
struct ModelRefused : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// `mesh` is in mm (after any scale); `source` names it ("part.stl (scale 1)"). The frames differ
// before registration, so sizes are compared, not positions: the model's largest extent along an
// axis must not exceed the travel box's diagonal, the longest segment any placement can fit.
void check_model_limits(const geometry::TriangleMesh& mesh, const description::TravelBox& travel_box, const std::string& source,
                        const ModelLimits& limits = {});

}  // namespace cmm::planner
