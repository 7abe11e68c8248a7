// A nominal (CAD) model as inspection reads it: its sharp edges (and open boundaries) as segments with
// the normals of the facets on each side, in the reference frame S once placed; its holes are found
// around the measured ones, as circles fitted to its sharp edges there.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/mesh.hpp"

namespace cmm::planner {

using geometry::Vec3;

struct NominalEdge {
  Vec3 a, b;              // the segment
  Vec3 n_first, n_second;  // outward normals of the two facets (the same one twice on an open boundary)
};

struct NominalModel {
  std::vector<NominalEdge> edges;
};

// The model's mesh moved by T_S_N into S and its sharp edges (facets meeting at more than
// feature_angle_deg; a nominal has no noise to filter) and open boundaries.
NominalModel nominal_model(const geometry::TriangleMesh& mesh, const Eigen::Isometry3d& T_S_N, double feature_angle_deg);

struct NearestNominalEdge {
  Vec3 point;  // on the segment
  const NominalEdge* edge = nullptr;
  double distance_mm = 0;
};

// The nearest point of the nominal's sharp edges within reach_mm of p, or nothing. Brute force over the
// segments: a CAD export has few, and a job asks for at most 20,000 points.
std::optional<NearestNominalEdge> nearest_nominal_edge(const NominalModel& model, const Vec3& p, double reach_mm);

struct NominalHole {
  Vec3 centre;  // of the entry rim
  Vec3 axis;    // unit, the sign of the axis it was looked for along
  double radius = 0;
};

// The nominal's entry rim of the hole whose reference rim is (rim_centre, axis, radius): a circle fitted
// to the nominal's sharp-edge vertices within max(0.5 mm, radius / 4) of that radius and 1 mm of the
// rim's plane. Nothing when fewer than 6 such vertices, or when they do not go at least half way round.
// (Looked for around each measured hole rather than taken from the feature code's holes, which finds
// its bores from reference points and so depends on how the rims were cut into facets.)
std::optional<NominalHole> nominal_hole_near(const NominalModel& model, const Vec3& rim_centre, const Vec3& axis, double radius);

}  // namespace cmm::planner
