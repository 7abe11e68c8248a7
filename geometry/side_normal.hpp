// The outward normal of one side of a sharp edge at a point, estimated from the faces of that side
// near the point (thesis §5.1's up/down patch normals), with its uncertainty.
#pragma once

#include <optional>
#include <vector>

#include "geometry/edge_adjacency.hpp"
#include "geometry/face_geometry.hpp"

namespace cmm::geometry {

struct SideNormal {
  Vec3 normal = Vec3::Zero();
  double uncertainty_rad = 0;   // standard error of `normal`'s turn about the edge (what moves a window)
  double facet_spread_rad = 0;  // RMS angle of the single facets about the fitted normal field
  int face_count = 0;
  // Set by the feature extractor: the side was taken beyond a fold of noise along the crease (its seed's
  // region was a sliver), and where the side's facets lie (area-weighted), which then says the edge's
  // convexity at this point better than the fold's own feature curve does.
  bool beyond_fold = false;
  Vec3 centroid = Vec3::Zero();
};

// Finds, for one side of an edge, the faces reachable from a seed face without crossing a feature or
// boundary edge, whose centroids lie within a radius of the point and whose (filtered) normals stay
// within max_turn of the seed's: the last bound keeps a region on a small bore from wrapping around
// it. Reuses its scratch between calls.
class SideRegionFinder {
 public:
  SideRegionFinder(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const FaceGeometry& faces,
                   const std::vector<char>& is_feature, const Points& similarity_normals, double max_turn_rad);
  // Faces within `radius` of the point and at most `along` from it along the edge's tangent: a
  // region long across the edge gathers faces, while keeping it short along the edge keeps a
  // rim's turning normals from foreshortening the mean.
  const std::vector<int>& region(int seed_face, const Vec3& centre, const Vec3& tangent, double radius, double along);
  const std::vector<int>& patch(int seed_face);

 private:
  const std::vector<int>& grow(int seed_face, const Vec3& centre, const Vec3& tangent, double radius, double along,
                               double min_cos, const Vec3& reference);

  const TriangleMesh& mesh_;
  const EdgeAdjacency& adjacency_;
  const FaceGeometry& faces_;
  const std::vector<char>& is_feature_;
  const Points& similarity_normals_;
  double min_cos_;
  std::vector<unsigned> stamp_;
  unsigned current_ = 0;
  std::vector<int> region_;
};

// Area-weighted normal of a side region at `point` on an edge along `tangent`. When the normals
// change measurably across the region (a curved side), the field is fitted linearly in the along-
// and across-edge coordinates and taken at the point itself: a one-sided average would be biased
// toward the region's middle. On a flat side the plain mean is kept, as it is the less noisy.
// `turn` (polyline_turn: axis × rate per unit length) is how the edge turns at the point: along a
// rim both sides turn with it, so each facet's normal is turned back by its centroid's angle about
// the circle's axis and the field fitted again. Without that, the fit's linear term follows the turn
// to first order only, and the second order leans a rim's normals by ~0.2° on a 25 mm circle even on
// an exact mesh. The normal's component along the edge stays the plain fit's.
//
// The uncertainty propagates the vertex noise through the fit. On a noisy mesh the noise is estimated
// from the facets' residuals about the field. On a clean one (`clean` given: the measured vertex
// noise) the residuals are the tessellation's, not noise: the region's noise figure is used, and
// the facets' chord angle is added, sized so that a window's margin is 5/8 of how far the fit moved the
// normal from the facet touching the edge (region.front(), the seed): nothing on a plane, where the two
// agree; on a curved side the fit's correction bounds what is left of the chord error. Where the fit
// moves the normal farther than the edge facet's chord angle (the turn to the facets bordering its plane
// piece, at most that over the next two rows), or its field misses the edge facet itself, on a side that
// is planar there or on a mesh whose vertices lie on the surface, it is following a blend beyond the
// edge, and the edge facet is kept with half its chord angle and its own vertex noise as error. A plane
// piece of several facets carries no vertex noise: its vertices lie on one plane.
// What a clean mesh's noise estimate says near a side: the figure for this region (the mesh's vertex
// noise, or its own vertices' RMS off their local fit where that is larger: a decimated patch, a blend
// the local quadric does not follow) and the whole mesh's (whether its vertices lie on its surface).
struct CleanNoise {
  double region_sigma_mm = 0;
  double mesh_sigma_mm = 0;
};

SideNormal side_normal(const TriangleMesh& mesh, const FaceGeometry& faces, const std::vector<int>& region,
                       const Vec3& point, const Vec3& tangent, const Vec3& turn = Vec3::Zero(),
                       std::optional<CleanNoise> clean = std::nullopt);

}  // namespace cmm::geometry
