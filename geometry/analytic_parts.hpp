// The analytic test parts, defined once and reused by the geometry and planner tests and the simulator:
// each comes as a watertight mesh at a target edge length together with its exact truth (edges, holes).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

// One sample of a true sharp edge, with the exact outward normals of its two sides at that point
// (n_up is the side whose normal has the larger +z, then +y, then +x component; DESIGN.md).
struct TrueEdgeSample {
  Vec3 position;
  Vec3 n_up;
  Vec3 n_down;
};

// A true sharp edge, densely sampled (chord error far below 1 µm); closed curves do not repeat
// their first sample.
struct TrueEdge {
  std::vector<TrueEdgeSample> samples;
  bool closed = false;
  bool convex = true;  // material angle below 180°
};

// A true cylindrical hole. `centre` lies on the rim the probe enters from, `axis` points out of the
// material there; `depth` is the length of the wall along the axis.
struct TrueHole {
  Vec3 centre;
  Vec3 axis;
  double radius = 0;
  double depth = 0;
};

struct AnalyticPart {
  std::string name;
  TriangleMesh mesh;
  std::vector<TrueEdge> sharp_edges;
  std::vector<TrueHole> holes;
  double size = 0;  // bounding-box diagonal, mm
};

// How a part's surfaces are cut into triangles: the kinds of mesh users bring.
struct Tessellation {
  enum class Style {
    uniform,  // near-equilateral triangles of about edge_length (a remesh, a scan's mesh)
    cad,      // as CAD systems export: fewest triangles per plane, fans and strips on curved faces
    slivers,  // cad, with circles cut 180 or 720 times and straight box edges every 0.5 mm: aspect ≥ 50
  };
  Style style = Style::uniform;
  double edge_length = 1.0;        // uniform
  double chord_tolerance = 0.025;  // cad, slivers: the largest distance of a facet from its curved surface
};

// The fewest segments that keep a circle's chords within chord_tolerance of it: R(1 − cos(π/n)) ≤ tol.
int circle_segments(double radius, double chord_tolerance);

// All parts stand on z = 0 in their own frame, in millimetres, with `edge_length` the target
// length of mesh edges (vertices of sharp edges lie exactly on the true edge).
AnalyticPart make_cube(double side_mm, double edge_length);
AnalyticPart make_cube(double side_mm, const Tessellation& tessellation);
// Thesis case 3: 88 × 95 × 41 mm block, one Ø42 and four Ø10 through holes from the top face.
// Hole axes (x, y): Ø42 at (44, 47.5); Ø10 at (13, 12.5), (75, 12.5), (13, 82.5), (75, 82.5).
AnalyticPart make_case3_block(double edge_length);
AnalyticPart make_case3_block(const Tessellation& tessellation);
// 120 × 80 × 10 mm plate with through holes of several diameters.
// Hole axes (x, y): Ø20 at (30, 40); Ø12 at (70, 25) and (70, 55); Ø6 at (100, 20); Ø8 at (100, 60).
AnalyticPart make_plate_with_holes(double edge_length);
AnalyticPart make_plate_with_holes(const Tessellation& tessellation);
// The same plate with two small true openings more: a Ø3 through hole at (10, 70) and a through slot
// 2 mm wide and 10 mm long along x, centred at (40, 10) (half circles of radius 1 at x = 36 and 44).
// The slot's rims are among sharp_edges (closed, not circles); it is no cylinder, so not among holes.
AnalyticPart make_plate_small_openings(double edge_length);
AnalyticPart make_plate_small_openings(const Tessellation& tessellation);
// Thesis Table 5.1: two cones of rim radius R and height H joined at their rims (axis z).
AnalyticPart make_bicone(double radius_mm, double height_mm, double edge_length);
AnalyticPart make_bicone(double radius_mm, double height_mm, const Tessellation& tessellation);
// Thesis Table 5.2: a hemisphere of radius R below a cone of height H on the same rim (axis z).
AnalyticPart make_hemisphere_cone(double radius_mm, double height_mm, double edge_length);
AnalyticPart make_hemisphere_cone(double radius_mm, double height_mm, const Tessellation& tessellation);

// The parts by name, at the sizes every tool and the simulator use (cube 40 mm; bicone R 25, H 37.5;
// hemisphere-cone R 25, H 25), so a plan, a scan and a simulated part of one name agree.
// cube, case3_block, plate_with_holes, plate_small_openings, bicone, hemisphere_cone
const std::vector<std::string>& analytic_part_names();
// Throws std::invalid_argument naming the known parts for any other name.
AnalyticPart make_analytic_part(const std::string& name, double edge_length);
AnalyticPart make_analytic_part(const std::string& name, const Tessellation& tessellation);

// Isotropic Gaussian noise of standard deviation sigma on every vertex coordinate; same seed, same mesh.
TriangleMesh with_gaussian_noise(const TriangleMesh& mesh, double sigma_mm, std::uint64_t seed);

}  // namespace cmm::geometry
