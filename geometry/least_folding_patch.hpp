// The triangulation of a closed loop in space that folds least (Liepa, "Filling holes in meshes", 2003):
// among all triangulations using the loop's vertices only, the one whose largest dihedral angle between
// neighbouring facets (the rim's own facets included) is smallest, then whose area is smallest (then whose
// longest diagonal is shortest: a flat loop's triangulations tie on both). It needs
// no plane to project the loop on, so a loop that folds or crosses itself seen from every side still
// gets a patch, and a loop along a crease gets facets lying in its faces where the vertices allow.
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct LeastFoldingPatch {
  std::vector<std::array<int, 3>> triangles;  // indices into the loop, wound against it
  double max_dihedral_rad = 0;                // the largest angle between neighbouring facets' normals
  double area = 0;
};

// `loop` runs the way the rim's facets run along their boundary: rim facet i holds the directed side
// loop[i] → loop[i + 1] and has the unit normal `rim_normals[i]` (zero: no facet there yet, as along a
// diagonal that splits a long loop into pieces; it adds no dihedral). The patch's triangles hold each side
// the other way, so a patch that continues the surface has normals like the rim's. `may_join(a, b)`
// says whether a diagonal between loop[a] and loop[b] may be made (false where the mesh already has
// that edge: the patch would make it non-manifold). Empty when no triangulation exists (fewer than 3
// vertices, every triangulation needing a forbidden diagonal or a degenerate triangle). O(n³) time,
// O(n²) memory: meant for loops of a few hundred vertices at most.
std::optional<LeastFoldingPatch> least_folding_patch(const std::vector<Vec3>& loop, const std::vector<Vec3>& rim_normals,
                                                     const std::function<bool(int, int)>& may_join);

}  // namespace cmm::geometry
