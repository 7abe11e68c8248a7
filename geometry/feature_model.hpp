// From a mesh to what the probe must re-measure: topology, feature curves, reference edge points
// at a spacing along sharp edges, hole rims and open boundaries, and the holes themselves.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/boundary_loops.hpp"
#include "geometry/cancellation.hpp"
#include "geometry/edge_point.hpp"
#include "geometry/feature_edges.hpp"
#include "geometry/hole.hpp"
#include "geometry/mesh_topology.hpp"

namespace cmm::geometry {

struct FeatureModelOptions {
  FeatureOptions features;
  double spacing = 2.0;  // between reference points along a curve, in mesh units
  // Radius of the neighbourhood each side normal is fitted over, in units of the vertex noise σ (mm):
  // wide enough to average the noise away (190 σ: 19 mm on a 0.1 mm scan), small enough to stay on
  // the side's own face. Never less than the facets touching the edge and the row beyond them (so
  // that a curved side's normal can be taken to the edge): on an exact mesh those alone are used.
  double neighbourhood_sigmas = 190.0;
  // ...and no farther than this along the edge, where a rim's turning normals would foreshorten (twice
  // this where the edge's turn can be taken out of the facets over that reach). A rim is smoothed over
  // as long a stretch.
  double neighbourhood_along_sigmas = 75.0;
  // ...and within this turn of the normal where it starts, so it cannot wrap around a small bore.
  double neighbourhood_max_turn_deg = 30.0;
  // A wall the scan lost is taken square to the hole's axis; this is the standard error granted to
  // that guess (a window's margin is 3.5 of them), for a draft or a tilt nobody measured.
  double inferred_wall_uncertainty_deg = 0.5;
  // A loop is a circle when its RMS radial residual is below this fraction of its radius.
  double circle_tolerance = 0.05;
  // Refused before any side normal is estimated (TooManyPoints): the curves' length / spacing would
  // give more reference points than this. 0: no limit.
  std::size_t max_points = 0;
  CancelCheck cancel;  // polled between steps and curves
};

// The model's curves at this spacing would give more reference points than options.max_points.
struct TooManyPoints : std::length_error {
  TooManyPoints(const std::string& what, std::size_t points, std::size_t limit)
      : std::length_error(what), points(points), limit(limit) {}
  std::size_t points, limit;
};

struct FeatureModel {
  TopologyReport topology;
  FeatureEdges features;
  std::vector<BoundaryLoop> loops;
  std::vector<EdgePoint> points;
  std::vector<Hole> holes;
  int rejected_curves = 0;  // feature curves whose two sides turned out to face the same way
  // Standard error of a typical reference point's position from the vertex noise: the median over the
  // points of EdgePoint::position_sigma_mm (the noise σ, reduced by the smoothing of a noisy mesh's
  // creases: a quadratic fit over 7 vertices keeps 1/3 of the variance). A plan's δ is raised to 3 of
  // it; a point smoothed less (a small rim, an open curve's end) raises its own.
  double point_sigma_mm = 0;
};

// Throws TooManyPoints, or Cancelled when options.cancel asks.
FeatureModel extract_features(const TriangleMesh& mesh, const FeatureModelOptions& options = {});

}  // namespace cmm::geometry
