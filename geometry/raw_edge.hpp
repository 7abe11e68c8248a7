// Where a scanned surface ends: the border vertices of a scan's mesh moved out onto the edge of the raw
// points they stand for. Thinning keeps the raw point nearest each bin's centre, so a border runs on
// average about B/4 inside the last raw points, and every opening comes out that much too large (the
// plate's Ø6 seen from above only: its rim fitted 2.3–3.4 % large at B 0.33 mm).
#pragma once

#include <optional>
#include <vector>

#include "geometry/cloud_index.hpp"
#include "geometry/mesh.hpp"
#include "geometry/region_growing.hpp"

namespace cmm::geometry {

struct RawEdgeOptions {
  double bin_mm = 1;            // the thinning's bin B
  double noise_sigma_mm = 0;    // the scan's noise σ
  double tolerance_mm = 0.1;    // ε: the mesh's largest distance from the scanned surface
};

// Where the raw surface ends beyond a border point `at`, along `outward` (unit, in the surface's plane
// `normal`, away from the mesh): the raw points in a strip 2 B wide across the border and near its plane
// (3σ + B/4) are ranked from the outermost in, down to 2 B deep, and the line their rank makes with their
// distance out (on a face sampled at random, the k-th lies k/(2ρB) inside the edge; on a grid the edge
// comes out half a row beyond the last; noise blurs the first few symmetrically about it) is followed
// out to rank 0, but no farther than a sample spacing beyond the outermost point. `out` is that distance
// from `at` along `outward`, `up` the height along `normal` of the strip's plane there. Nothing where
// fewer than 6 points say it, or where the face is not flat at the bin's scale (the quadric fitted to the
// points within 3 B bends by κ with κB² > ε/2): a border moved a bin out lengthens its facets, whose
// sagitta on a curved face then grows by about κB²/2, more than ε allows at the bicone's Ø6 end at
// ε 0.02 mm.
struct RawEdge {
  double out = 0, up = 0;
};
std::optional<RawEdge> raw_edge(const Points& raw, const CloudIndex& index, const Vec3& at, const Vec3& normal,
                                const Vec3& outward, const RawEdgeOptions& options);

// Moves each border vertex of `t`'s hole loops (not a crease point, on one loop only) outward in its face's
// plane onto the raw edge and the surface there, by at most B and never inward; a move that would turn one
// of its facets by more than 30° is not made. The outer loops stay: a scan's outer border is mostly where a
// face turns away from every view, seen at a grazing angle, where beam noise spills the points along the
// face past its edge. Returns how many vertices moved.
int move_borders_to_raw_edge(Triangulation& t, const Points& raw, const CloudIndex& index, const RawEdgeOptions& options);

}  // namespace cmm::geometry
