// Sharp creases of a raw scan, where two smooth faces meet at an angle: found from the local fits,
// placed on the intersection of the two faces' fitted planes, sampled every bin and smoothed along
// the crease, so that the triangulation can carry each crease as a chain of mesh edges instead of
// chamfering it.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "geometry/cancellation.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/local_surface.hpp"
#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct CreasePoint {
  Vec3 position = Vec3::Zero();
  // Unit normals (sign not oriented) of the faces that meet here: 2 on a crease, 3 at a corner.
  std::array<Vec3, 3> normals{Vec3::UnitZ(), Vec3::UnitZ(), Vec3::UnitZ()};
  int sides = 2;
};

struct CreasePolyline {
  std::vector<int> points;  // into Creases::points; consecutive points are joined by a crease edge
  bool closed = false;      // the last point joins the first
  // The faces on either side of the polyline (unoriented unit normals), where it runs straight.
  Vec3 normal_a = Vec3::UnitZ(), normal_b = Vec3::UnitX();
};

struct Creases {
  std::vector<CreasePoint> points;  // corners first, then the polylines' own points
  std::vector<CreasePolyline> polylines;
  std::size_t corners = 0;
};

struct CreaseOptions {
  double bin_mm = 1;             // the thinning's bin B: crease points come every ≈ B
  double crease_angle_deg = 30;  // two faces meeting at less than this are one smooth face
  double fit_radius_bins = 2;    // each side's plane is fitted over raw points this many bins around
  CancelCheck cancel;
};

// `fits` and `index` belong to `raw`. Deterministic.
Creases find_creases(const Points& raw, const std::vector<LocalSurface>& fits, const CloudIndex& index,
                     const CreaseOptions& options = {});

}  // namespace cmm::geometry
