// The "scanned reference mesh" of a true part: its mesh with scanner-level vertex noise and without the
// faces no view sees, as the meshed scan the planner starts from would be, with the truth to compare.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/mesh.hpp"
#include "sim/scan_views.hpp"
#include "sim/visibility.hpp"

namespace cmm::sim {

struct ScannedMeshOptions {
  double noise_sigma_mm = 0.05;  // Gaussian, per vertex coordinate (δ-level)
  std::vector<ScanView> views = default_views();
  double max_incidence_deg = kDefaultMaxIncidenceDeg;
  std::uint64_t seed = 1;
};

struct ScannedMesh {
  geometry::TriangleMesh mesh;     // no vertex normals; only vertices some kept face uses
  std::vector<int> true_vertex;    // per output vertex: the true mesh's vertex it is a noisy copy of
  std::vector<int> removed_faces;  // true faces no view sees, ascending
};

// `true_mesh` is the part already meshed at the wanted edge length (e.g. geometry::make_case3_block(1.0)).
// A face is kept when its centroid is seen (ScanVisibility::sees) by at least one view; the views'
// registration errors play no part here. Same options, same mesh. Throws std::invalid_argument naming
// the bad option.
ScannedMesh synthesize_scanned_mesh(const geometry::TriangleMesh& true_mesh, const ScannedMeshOptions& options = {});

}  // namespace cmm::sim
