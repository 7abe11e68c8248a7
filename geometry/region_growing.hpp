// Region-growing triangulation of a thinned scan (thesis Ch. 4, §4.2–4.3), with the creases joined:
// points put on each sharp edge (crease_points) are vertices of both faces, no facet straddles the
// edge, and the two faces share it as mesh edges, so boundary loops are left only at the real openings.
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
  double fold_angle_deg = 45;      // §4.2.2 (3): largest turn between neighbouring facets off the creases
  double max_edge_bins = 2.5;      // no edge longer than this many bins (√3 B spans neighbouring bins)
  // Thinned points closer than this many bins to one kept before them are left out: a noisy surface
  // puts points in bins stacked across it, and such pairs would only make slivers and folds.
  double min_spacing_bins = 0.5;
  // Per thinned point, the longest edge it may have (adaptive bins: max_edge_bins times its own bin; a
  // sparse face: its sampling's, sparse_reach in scan_front_end.cpp);
  // empty: max_edge_bins·bin_mm for every point. Crease points take max_edge_bins·bin_mm.
  std::vector<double> reach_mm;
  // Whether reach_mm is each point's own bin's (adaptive bins: a point is crowded at min_spacing_bins of
  // its own bin) or its sampling's, on a face sparser than B needs (crowded at min_spacing_bins of B, as
  // any: a sparse face has no points to spare).
  bool reach_from_bins = true;
  // The scan's noise σ off the surface: a point whose fit was irregular keeps its raw, noisy place,
  // so the gap-closing pass allows loops this much (×3) off flat.
  double noise_sigma_mm = 0;
  CancelCheck cancel;
};

struct ScanLoop {
  LoopKind kind = LoopKind::outer;
  std::vector<int> vertices;  // in the faces' winding order: the surface lies to the left
  double perimeter_mm = 0;
};

struct CreaseLine {
  std::vector<int> vertices;  // mesh vertices along the crease; consecutive ones share a mesh edge
  bool closed = false;
};

struct Triangulation {
  // vertices: the thinned points the facets use, in order, then the crease points they use, then the
  // points the hole filling put on the creases its patches cross. Thinned points in a crease's band
  // (within B/2 of it) and crowded ones (min_spacing_bins) are left out; those within 3B of a crease
  // lie on the plane of their face there.
  TriangleMesh mesh;
  std::vector<int> thinned_index;  // per mesh vertex: its row in `thinned`, or −1 for a crease point
  std::vector<ScanLoop> loops;
  std::vector<CreaseLine> crease_lines;
  std::size_t components = 0;
  std::size_t creases = 0;        // crease polylines joined
  std::size_t crease_points = 0;  // vertices added on them
  std::size_t seeds = 0;          // seed triangles the growth started from
  std::size_t holes_filled = 0;   // false holes closed after the growth (hole_filling)
  std::size_t pinched_vertices = 0;  // vertices on two boundary fans (edge-manifold, not vertex-manifold)
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
