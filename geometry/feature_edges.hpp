// Sharp feature edges: mesh edges whose dihedral angle exceeds a threshold, chained into curves
// and flagged convex or concave. The vertex noise is measured first, and a noisy mesh's normals filtered.
#pragma once

#include <vector>

#include "geometry/cancellation.hpp"
#include "geometry/edge_adjacency.hpp"
#include "geometry/face_geometry.hpp"
#include "geometry/surface_noise.hpp"

namespace cmm::geometry {

struct FeatureOptions {
  double angle_deg = 30;  // dihedral angle between face normals above which an edge is sharp
  // A curve's free end is extended along edges above this fraction of angle_deg that continue its
  // direction (hysteresis, as in Canny's edge detector): noise dips a crease below the threshold
  // here and there, and a gap would cut one edge into pieces whose sides leak into each other.
  double continuation_fraction = 0.5;
  // A mesh is treated as noisy (its normals filtered before the threshold, its creases smoothed, its
  // sides fitted over a neighbourhood) when its vertex noise, measured on the surface in mm
  // (surface_noise), tilts facets of its mean edge length by more than this: 2σ/L radians. 0.1 mm on
  // 1 mm edges tilts them by 11°, 10 µm on 0.2 mm edges by 6°; a decimated mesh's 7 µm on 3 mm edges
  // by 0.3°, and an exact mesh's less than 1 µm not at all, however coarse or thin its triangles.
  double noisy_facet_tilt_deg = 1.0;
  // A mesh the scan front end made is noisy whatever its vertex scatter: its vertices sit on quadrics
  // fitted to noisy neighbourhoods (smooth together, they lean together where a face is sparse) and the
  // facets beside a crease lean with the crease's estimate, so a single facet there says little of its
  // side. (Taken from the scatter, the plate's Poisson-disk scan without noise was clean and its plan
  // called 24 rim points concave, 91 % probeable, 97.5 % as noisy; the case-3 block's grid scan at 100k
  // points, σ 0.05 mm, 30 on its back edges, 73 % probeable, 82 % as noisy.)
  bool made_from_scan = false;
  // Curves that end in nothing (or, on a noisy mesh, close on themselves) and are shorter than this
  // many mean edge lengths are dropped: on a clean mesh they are the spokes of a coarsely tessellated
  // cone apex, on a noisy one specks and spurs of noise. A true crease ending in a smooth blend is
  // longer; a clean mesh's closed loop is kept whatever its length (a small hole's rim).
  double min_dangling_edges = 3;
  double noisy_min_dangling_edges = 5;
  // Curves attached to nothing at either end, and the spokes of a star junction (every curve at it
  // ends in nothing: a cone tip), go up to this length: noise keeps the facets near an apex folded
  // for a while down the cone.
  double min_spoke_edges = 8;
  double noisy_min_spoke_edges = 16;
  CancelCheck cancel;  // polled between the steps (and the normal filter's iterations)
};

// A chain of feature edges between junctions (vertices where other than two feature edges meet) or
// free ends, or a closed loop. Closed curves do not repeat their first vertex.
struct FeatureCurve {
  std::vector<int> vertices;
  std::vector<int> edges;  // edges[i] joins vertices[i] and vertices[i + 1] (closed: wraps)
  bool closed = false;
  bool convex = true;      // by edge-length majority
  double length = 0;
};

struct FeatureEdges {
  std::vector<char> is_feature;  // per edge
  std::vector<FeatureCurve> curves;
  SurfaceNoise noise;
  double mean_edge_length = 0;
  bool noisy = false;  // FeatureOptions::noisy_facet_tilt_deg
  Points filtered_normals;  // F × 3 bilateral-filtered face normals when noisy, else empty
};

FeatureEdges feature_edges(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const FaceGeometry& faces,
                           const FeatureOptions& options = {});

}  // namespace cmm::geometry
