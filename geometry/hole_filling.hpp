// Closing the false holes region growing leaves under noise: a small boundary loop with raw scan points
// across it is a gap in the triangulation, not a border of the scanned region, and is filled flat.
#pragma once

#include <cstddef>

#include "geometry/cloud_index.hpp"
#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct HoleFillingOptions {
  double bin_mm = 1;                // the thinning's bin size B
  double max_perimeter_bins = 60;   // longer loops are left alone: a crack that long is no patch to guess
  double support_bins = 1;          // a point of the patch is backed by a raw point this close
  double min_support = 0.9;         // fraction of the patch's sample points that must be backed,
  double max_gap_bins = 1.5;        // or: no sample farther than this from the cloud (a sampling void)
  double crease_angle_deg = 30;     // a loop whose faces turn more than this spans a crease
  double flatness_bins = 0.25;      // a loop filled flat lies within this of its mean plane,
  double noise_sigma_mm = 0;        // plus 3 σ of the scan's noise (vertices whose fit was irregular stay raw)
  // Rounds of: fill, then cut back the rim facets of the loops no patch closed, and fill again. More
  // than one closes more loops on the case-3 scan (22 left instead of 52) but the wider patches misplace
  // edges by up to 0.14 mm, so one is the default.
  int rounds = 1;
  // Then this many more rounds for the failed loops no longer than small_loop_bins·B alone, or no longer
  // than pinhole_loop_bins·B with raw points at their middle (nearer than max_gap_bins·B): a tangle at a
  // small rim (a slot's end at 3 B), where the mouth of an opening is empty across its whole width.
  int small_loop_rounds = 2;
  double small_loop_bins = 10;
  double pinhole_loop_bins = 30;
};

struct HoleFilling {
  std::size_t loops_examined = 0;  // loops short enough to be a gap
  std::size_t loops_filled = 0;
  std::size_t faces_added = 0;
  std::size_t vertices_added = 0;  // on the creases the filled loops straddle, appended to the mesh
  std::size_t faces_removed = 0;   // around loops no patch could close, before the next round
};

// Fills, in `mesh`, each boundary loop short enough (split where it passes a vertex twice) whose patch
// lies on the raw scan: `raw` and `raw_index` are the outlier-free cloud. A real opening has no scan
// points across it and stays open. A loop on one face is ear-clipped in its mean plane; one whose sides
// lie on two faces is clipped on each face up to new vertices on their intersection line (appended to
// the mesh's vertices), so the crease stays sharp. Patches are wound against the loop, so a consistently
// oriented mesh stays so; a loop whose projection crosses itself or whose every triangulation needs an
// edge the mesh already has is left open, or with rounds > 1 has its rim facets cut and is tried again,
// wider (vertices may be left without a facet). The mesh stays edge-manifold. CMMD_DUMP_FILL=1 prints
// each loop's verdict. Deterministic.
HoleFilling fill_false_holes(TriangleMesh& mesh, const Points& raw, const CloudIndex& raw_index,
                             const HoleFillingOptions& options);

}  // namespace cmm::geometry
