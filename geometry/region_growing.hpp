// Region-growing triangulation of a thinned scan (thesis Ch. 4, §4.2–4.3), with the creases joined:
// growth stops where a new facet would fold across a sharp edge, and the two faces then share the
// crease as a mesh edge, so boundary loops are left only at the real openings of the scan.
#pragma once

#include <cstddef>
#include <vector>

#include "geometry/boundary_loops.hpp"
#include "geometry/cancellation.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/local_surface.hpp"
#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct RegionGrowingOptions {
  double bin_mm = 1;               // the thinning's bin size B: the search reaches the 26 bins around an edge's ends
  double min_angle_deg = 10;       // thesis §4.2.2 (2): no facet angle below this
  double crease_angle_deg = 30;    // a facet that turns more than this from its neighbour folds across a crease
  CancelCheck cancel;
};

struct ScanLoop {
  LoopKind kind = LoopKind::outer;
  std::vector<int> vertices;  // in the faces' winding order: the surface lies to the left
  double perimeter_mm = 0;
};

struct Triangulation {
  TriangleMesh mesh;  // vertices: the thinned points first, in order, then the crease points added
  std::vector<ScanLoop> loops;
  std::size_t components = 0;
  std::size_t creases = 0;        // crease polylines joined
  std::size_t crease_points = 0;  // vertices added on them
};

// `thinned`: the kept points; `raw`, `raw_fits`, `raw_index`: the whole (outlier-free) cloud and its
// local fits, which say where the creases run; `raw_normals`: the scanner's normals of `raw` (N × 3,
// pointing out of the material) or 0 × 3 when the file had none. Terminates on any input; never emits an overlapping,
// flipped or non-manifold facet; every component is consistently oriented, outward where the scan's
// normals say so. Deterministic.
Triangulation triangulate_scan(const Points& thinned, const Points& raw, const std::vector<LocalSurface>& raw_fits,
                               const CloudIndex& raw_index, const Points& raw_normals,
                               const RegionGrowingOptions& options);

}  // namespace cmm::geometry
