// The advancing front of the thesis's region growing (Ch. 4, §4.2–4.3) over a fixed vertex set:
// seed triangles, the suitable-point rules, the loop bookkeeping of every case of §4.3, and the
// guards that keep a new facet from overlapping, flipping or folding across a crease.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "geometry/cancellation.hpp"
#include "geometry/mesh.hpp"

namespace cmm::geometry {

// The surface a vertex lies on: one unoriented unit normal on a smooth face, two on a crease, three
// at a corner (0: unknown, any facet will do). A facet at the vertex must agree with one of them.
struct VertexSurface {
  std::array<Vec3, 3> normals{Vec3::UnitZ(), Vec3::UnitZ(), Vec3::UnitZ()};
  int count = 0;
  double cos_tolerance = 0.5;  // |facet normal · normal| at least this
  // The crease polyline the vertex lies on (−1: none; −2: a corner, on several): two points of one
  // crease are joined only by its own crease edges, never across a point of it.
  int crease = -1;
};

// Two consecutive crease points: the facets on its two sides lie on the faces of these normals.
struct CreaseEdge {
  int a = 0, b = 0;
  Vec3 normal_a = Vec3::UnitZ(), normal_b = Vec3::UnitX();
  double cos_tolerance = 0.866;  // a facet across it lies on the other face this well (|cos|)
};

struct FrontOptions {
  double bin_mm = 1;
  double min_angle_deg = 10;
  double fold_angle_deg = 45;        // largest turn between a facet and the one it grows from
  double max_edge_bins = 2.5;        // no edge longer than this many bins (√3 B between neighbour bins, and some)
  // Per vertex, the longest edge it may have (adaptive bins: its own bin's reach; a sparse face: its
  // sampling's); an edge is no longer than the smaller of its ends' reaches, or with
  // `larger_reach_joins` the larger. Empty: max_edge_bins·bin_mm for all.
  std::vector<double> reach_mm;
  CancelCheck cancel;
  // The seed normals came from a scanner and agree with each other: a facet that faces against those
  // of its corners is grown inside out (a fold through a small bore's mouth) and is refused.
  bool seed_normals_oriented = false;
  // Sparse reaches: a sparse face's points lie farther from the denser face they run into than that
  // face's own reach, and with the smaller reach the two never join (a wall's lower half seen only by a
  // sparse view grew apart from the rest and was dropped as a speck). Adaptive bins keep the smaller: a
  // coarse bin's chord over a fine bin's curve is off by more than ε.
  bool larger_reach_joins = false;
};

struct FrontResult {
  Triangles faces;  // consistently oriented within each edge-connected patch
  std::size_t seeds = 0;
  std::size_t pinched_vertices = 0;  // on two boundary fans at the end
};

// `seed_normals`: per vertex, the side a seed triangle at it faces (oriented; zero: use its surface
// normal as it is); `can_seed`: vertices a seed may start from. Deterministic; terminates on any input.
FrontResult grow_front(const Points& vertices, const std::vector<VertexSurface>& surfaces,
                       const std::vector<Vec3>& seed_normals, const std::vector<char>& can_seed,
                       const std::vector<CreaseEdge>& creases, const FrontOptions& options);

}  // namespace cmm::geometry
