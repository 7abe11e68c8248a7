// Sharp feature edges: mesh edges whose dihedral angle exceeds a threshold, chained into curves
// and flagged convex or concave. Noisy meshes are detected and their normals filtered first.
#pragma once

#include <vector>

#include "geometry/cancellation.hpp"
#include "geometry/edge_adjacency.hpp"
#include "geometry/face_geometry.hpp"

namespace cmm::geometry {

struct FeatureOptions {
  double angle_deg = 30;  // dihedral angle between face normals above which an edge is sharp
  // A curve's free end is extended along edges above this fraction of angle_deg that continue its
  // direction (hysteresis, as in Canny's edge detector): noise dips a crease below the threshold
  // here and there, and a gap would cut one edge into pieces whose sides leak into each other.
  double continuation_fraction = 0.5;
  // A mesh whose median dihedral angle exceeds this is treated as noisy: its normals are filtered
  // before the threshold.
  double noisy_median_deg = 4;
  // Curves that end in nothing (or close on themselves) and are shorter than this many mean edge
  // lengths are dropped: on a
  // clean mesh they are the spokes of a coarsely tessellated cone apex, on a noisy one specks and
  // spurs of noise. A true crease ending in a smooth blend is longer.
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
  double median_dihedral_deg = 0;
  double mean_edge_length = 0;
  bool noisy = false;
  Points filtered_normals;  // F × 3 bilateral-filtered face normals when noisy, else empty
};

FeatureEdges feature_edges(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const FaceGeometry& faces,
                           const FeatureOptions& options = {});

}  // namespace cmm::geometry
