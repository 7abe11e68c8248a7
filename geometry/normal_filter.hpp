// Bilateral filtering of face normals (Zheng et al. 2011): smooths scanner noise on the faces while
// keeping creases, so a noisy mesh's random facet tilts do not read as sharp edges.
#pragma once

#include "geometry/cancellation.hpp"
#include "geometry/edge_adjacency.hpp"
#include "geometry/face_geometry.hpp"

namespace cmm::geometry {

struct NormalFilterOptions {
  int iterations = 10;
  // Gaussian width on |n_i − n_j|; 0.25 ≈ 14°: facet noise of ±10° is averaged, while across a
  // 45° crease (|Δn| = 0.77) the weight is below 1 %, so the crease survives the iterations.
  double normal_sigma = 0.25;
  CancelCheck cancel;  // polled between iterations (a few hundred ms each on 2 M faces)
};

// Filtered unit normals, one per face; neighbours are the faces across each edge.
Points bilateral_filtered_normals(const TriangleMesh& mesh, const EdgeAdjacency& adjacency,
                                  const FaceGeometry& faces, const NormalFilterOptions& options = {});

}  // namespace cmm::geometry
