// Region-growing triangulation of thinned scans (thesis Ch. 4) on sampled parts: the loops it leaves
// are the real openings, the creases are mesh edges the feature extractor finds, and the mesh is
// always edge-manifold, consistently oriented and free of overlaps, whatever the input.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <random>

#include "edge_truth.hpp"
#include "geometry/analytic_parts.hpp"
#include "geometry/edge_adjacency.hpp"
#include "geometry/feature_model.hpp"
#include "geometry/local_surface.hpp"
#include "geometry/mesh_topology.hpp"
#include "geometry/region_growing.hpp"
#include "scan_samples.hpp"

namespace cmm::geometry {
namespace {

using testing::sample_faces;
using testing::voxel_thin;

struct Grown {
  Triangulation t;
  std::size_t thinned = 0;
  double seconds = 0;
};

Grown triangulate(const PointCloud& raw, double bin, bool scanner_normals = true, RegionGrowingOptions options = {}) {
  const CloudIndex index(raw.points);
  const std::vector<LocalSurface> fits = fit_local_surfaces(raw.points, index);
  const Points thinned = voxel_thin(raw.points, bin);
  options.bin_mm = bin;
  const auto start = std::chrono::steady_clock::now();
  Grown run;
  run.t = triangulate_scan(thinned, raw.points, fits, index, scanner_normals ? raw.normals : Points(0, 3), options);
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.thinned = static_cast<std::size_t>(thinned.rows());
  return run;
}

std::size_t loops_of(const Triangulation& t, LoopKind kind) {
  std::size_t n = 0;
  for (const ScanLoop& l : t.loops) n += l.kind == kind;
  return n;
}

double facet_min_angle_deg(const TriangleMesh& m, Eigen::Index f) {
  double worst = 180;
  for (int k = 0; k < 3; ++k) {
    const Vec3 p = vertex(m, m.faces(f, k)), u = vertex(m, m.faces(f, (k + 1) % 3)) - p, w = vertex(m, m.faces(f, (k + 2) % 3)) - p;
    worst = std::min(worst, std::acos(std::clamp(u.dot(w) / (u.norm() * w.norm()), -1.0, 1.0)) * 180 / std::numbers::pi);
  }
  return worst;
}

double min_angle_deg(const TriangleMesh& m) {
  double worst = 180;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) worst = std::min(worst, facet_min_angle_deg(m, f));
  return worst;
}

double area(const TriangleMesh& m) {
  double a = 0;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    a += 0.5 * (vertex(m, m.faces(f, 1)) - vertex(m, m.faces(f, 0))).cross(vertex(m, m.faces(f, 2)) - vertex(m, m.faces(f, 0))).norm();
  return a;
}

int facets_below(const TriangleMesh& m, double deg) {
  int n = 0;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) n += facet_min_angle_deg(m, f) < deg;
  return n;
}

// Edge-manifold, consistently oriented, no facet below the minimum angle but the slivers that close
// a triangular gap (strict: none at all).
TopologyReport expect_sound(const Grown& run, const char* name, bool strict = false) {
  const TriangleMesh& m = run.t.mesh;
  const TopologyReport topo = topology_report(m, edge_adjacency(m));
  EXPECT_EQ(topo.non_manifold_edges, 0u) << name;
  EXPECT_EQ(topo.inconsistently_oriented_edges, 0u) << name;
  const int slivers = facets_below(m, 10 - 1e-9);
  if (strict) {
    EXPECT_EQ(slivers, 0) << name;
  } else {
    EXPECT_LE(slivers, m.faces.rows() / 100) << name;
  }
  std::size_t holes = loops_of(run.t, LoopKind::hole), outer = loops_of(run.t, LoopKind::outer);
  if (std::getenv("CMMD_DUMP_LOOPS"))
    for (const CreaseLine& l : run.t.crease_lines)
      std::printf("    crease of %zu points%s from %s to %s\n", l.vertices.size(), l.closed ? " (closed)" : "",
                  ::testing::PrintToString(vertex(m, l.vertices.front()).transpose()).c_str(),
                  ::testing::PrintToString(vertex(m, l.vertices.back()).transpose()).c_str());
  if (std::getenv("CMMD_DUMP_LOOPS"))
    for (const ScanLoop& l : run.t.loops) {
      Vec3 c = Vec3::Zero();
      for (int v : l.vertices) c += vertex(m, v) / double(l.vertices.size());
      std::printf("    loop %s of %zu vertices, %.2f mm, around %s\n", l.kind == LoopKind::outer ? "outer" : "hole",
                  l.vertices.size(), l.perimeter_mm, ::testing::PrintToString(c.transpose()).c_str());
    }
  std::printf("[ %s ] %zu thinned -> %ld vertices, %ld facets in %.3f s (%.0f facets/s); %zu components, %zu outer, "
              "%zu holes, %zu creases, %zu crease points, %zu seeds, %zu pinched, min angle %.1f (%d facets below 10)\n",
              name, run.thinned, long(m.vertices.rows()), long(m.faces.rows()), run.seconds, m.faces.rows() / std::max(run.seconds, 1e-9),
              run.t.components, outer, holes, run.t.creases, run.t.crease_points, run.t.seeds, run.t.pinched_vertices,
              m.faces.rows() ? min_angle_deg(m) : 0.0, slivers);
  return topo;
}

// On a plane z = 0 (normals +z) the facets cover exactly the region the loops bound when none overlaps.
void expect_no_overlap_in_plane(const Triangulation& t) {
  double signed_sum = 0;
  for (Eigen::Index f = 0; f < t.mesh.faces.rows(); ++f) {
    const Vec3 a = vertex(t.mesh, t.mesh.faces(f, 0)), b = vertex(t.mesh, t.mesh.faces(f, 1)), c = vertex(t.mesh, t.mesh.faces(f, 2));
    const double z = 0.5 * (b - a).cross(c - a).z();
    EXPECT_GT(z, 0) << "facet " << f << " flipped";
    signed_sum += z;
  }
  double bounded = 0;
  for (const ScanLoop& l : t.loops) {
    double s = 0;
    for (std::size_t i = 0; i < l.vertices.size(); ++i) {
      const Vec3 p = vertex(t.mesh, l.vertices[i]), q = vertex(t.mesh, l.vertices[(i + 1) % l.vertices.size()]);
      s += 0.5 * p.cross(q).z();
    }
    bounded += s;  // holes run clockwise: negative
  }
  EXPECT_NEAR(signed_sum, bounded, 1e-6 * std::abs(bounded));
}

TEST(RegionGrowing, FlatSquareIsOneDiscWithOneOuterLoop) {
  const PointCloud raw = sample_faces(testing::rectangle(20, 20), 0.25, 0, 1);
  const Grown run = triangulate(raw, 1.0);
  expect_sound(run, "flat square", true);
  EXPECT_EQ(run.t.components, 1u);
  EXPECT_EQ(loops_of(run.t, LoopKind::outer), 1u);
  EXPECT_EQ(loops_of(run.t, LoopKind::hole), 0u);
  EXPECT_EQ(run.t.creases, 0u);
  expect_no_overlap_in_plane(run.t);
  EXPECT_GT(area(run.t.mesh), 0.9 * 400);
}

TEST(RegionGrowing, PlateWithACircularHoleHasOneHoleLoop) {
  const PointCloud square = sample_faces(testing::rectangle(24, 24), 0.25, 0, 2);
  PointCloud raw;
  std::vector<Eigen::Index> kept;
  for (Eigen::Index i = 0; i < square.points.rows(); ++i)
    if ((square.points.row(i) - Eigen::RowVector3d(12, 12, 0)).norm() > 5) kept.push_back(i);
  raw.points = square.points(kept, Eigen::all);
  raw.normals = square.normals(kept, Eigen::all);
  const Grown run = triangulate(raw, 1.0);
  expect_sound(run, "plate with hole", true);
  EXPECT_EQ(run.t.components, 1u);
  EXPECT_EQ(loops_of(run.t, LoopKind::outer), 1u);
  EXPECT_EQ(loops_of(run.t, LoopKind::hole), 1u);
  expect_no_overlap_in_plane(run.t);
}

TEST(RegionGrowing, HemisphereIsOneDiscWithinTheChordError) {
  const double r = 10;
  std::mt19937_64 rng(3);
  const int n = static_cast<int>(2 * std::numbers::pi * r * r / (0.25 * 0.25));
  PointCloud raw;
  raw.points.resize(n, 3);
  raw.normals.resize(n, 3);
  for (int i = 0; i < n; ++i) {  // Archimedes: z uniform gives area-uniform points on the cap
    const double z = r * (rng() >> 11) * 0x1.0p-53, phi = 2 * std::numbers::pi * (rng() >> 11) * 0x1.0p-53;
    const double rho = std::sqrt(r * r - z * z);
    raw.points.row(i) << rho * std::cos(phi), rho * std::sin(phi), z;
    raw.normals.row(i) = raw.points.row(i) / r;
  }
  const Grown run = triangulate(raw, 1.0);
  expect_sound(run, "hemisphere");
  EXPECT_EQ(run.t.components, 1u);
  EXPECT_EQ(loops_of(run.t, LoopKind::outer), 1u);
  EXPECT_EQ(loops_of(run.t, LoopKind::hole), 0u);
  // Facet centroids sink inside the sphere by at most the chord error of the longest edges.
  const double longest = 2.5;
  double worst = 0;
  for (Eigen::Index f = 0; f < run.t.mesh.faces.rows(); ++f) {
    Vec3 c = Vec3::Zero();
    for (int k = 0; k < 3; ++k) c += vertex(run.t.mesh, run.t.mesh.faces(f, k)) / 3;
    worst = std::max(worst, r - c.norm());
    const Vec3 a = vertex(run.t.mesh, run.t.mesh.faces(f, 0)), b = vertex(run.t.mesh, run.t.mesh.faces(f, 1)),
               d = vertex(run.t.mesh, run.t.mesh.faces(f, 2));
    EXPECT_GT((b - a).cross(d - a).dot(c), 0) << "facet " << f << " faces inward";
  }
  EXPECT_LT(worst, longest * longest / (6 * r));
  EXPECT_GT(area(run.t.mesh), 0.9 * 2 * std::numbers::pi * r * r);
}

TEST(RegionGrowing, ClosedCubeJoinsItsTwelveCreases) {
  const AnalyticPart cube = make_cube(10, 0.5);
  const PointCloud raw = sample_faces(cube.mesh, 0.2, 0, 4);
  const Grown run = triangulate(raw, 1.0);
  const TopologyReport topo = expect_sound(run, "cube");
  EXPECT_TRUE(topo.closed());
  EXPECT_EQ(run.t.loops.size(), 0u);
  EXPECT_EQ(run.t.components, 1u);
  EXPECT_EQ(run.t.creases, 12u);
  EXPECT_EQ(topo.euler_characteristic, 2);
  EXPECT_NEAR(area(run.t.mesh), 600, 1e-6);
  // Crease vertices on the true edges.
  double worst = 0;
  for (const CreaseLine& line : run.t.crease_lines)
    for (int v : line.vertices) worst = std::max(worst, nearest_true_edge(cube, vertex(run.t.mesh, v)).distance);
  std::printf("    crease vertices: worst distance from the true edges %.3g mm\n", worst);
  EXPECT_LT(worst, 1e-3 * 1e-3 * 1000);  // 1 µm

  const FeatureModel model = extract_features(run.t.mesh);
  EXPECT_EQ(model.features.curves.size(), 12u);
  double worst_normal = 0;
  int sharp = 0;
  for (const EdgePoint& p : model.points) {
    if (p.kind != EdgeKind::sharp_edge) continue;
    ++sharp;
    const auto truth = nearest_true_edge(cube, p.position);
    EXPECT_LT(truth.distance, 0.01);
    ASSERT_TRUE(p.n_down.has_value());
    worst_normal = std::max({worst_normal, testing::angle_deg(p.n_up, truth.at.n_up), testing::angle_deg(*p.n_down, truth.at.n_down)});
  }
  std::printf("    extract_features: %zu curves, %d sharp-edge points, worst side normal %.3f deg, coverage %.3f\n",
              model.features.curves.size(), sharp, worst_normal, testing::covered_fraction(cube, model, 1.5));
  EXPECT_LT(worst_normal, 2.0);
  EXPECT_GT(testing::covered_fraction(cube, model, 1.5), 0.95);
}

TEST(RegionGrowing, OpenBoxHasOneOuterLoopAtTheBottom) {
  const AnalyticPart cube = make_cube(10, 0.5);
  const PointCloud raw = sample_faces(cube.mesh, 0.2, 0, 5, [](const Vec3& n, const Vec3&) { return n.z() > -0.5; });
  const Grown run = triangulate(raw, 1.0);
  expect_sound(run, "open box");
  EXPECT_EQ(run.t.components, 1u);
  ASSERT_EQ(run.t.loops.size(), 1u);
  EXPECT_EQ(run.t.loops[0].kind, LoopKind::outer);
  double top = -1;
  for (int v : run.t.loops[0].vertices) top = std::max(top, run.t.mesh.vertices(v, 2));
  EXPECT_LT(top, 1.0) << "the loop runs around the bottom";
  EXPECT_GE(run.t.creases, 8u);
}

// The exact bicone of make_bicone (apexes at z = 0 and 2h, rim of radius r at z = h), sampled
// area-uniformly on its two cones.
PointCloud sample_bicone(double r, double h, double spacing, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const double slant = std::hypot(r, h);
  const int per_cone = static_cast<int>(std::numbers::pi * r * slant / (spacing * spacing));
  PointCloud cloud;
  cloud.points.resize(2 * per_cone, 3);
  cloud.normals.resize(2 * per_cone, 3);
  for (int i = 0; i < 2 * per_cone; ++i) {
    const double t = std::sqrt((rng() >> 11) * 0x1.0p-53), phi = 2 * std::numbers::pi * (rng() >> 11) * 0x1.0p-53;
    const bool upper = i >= per_cone;
    const double z = upper ? 2 * h - h * t : h * t;
    cloud.points.row(i) << r * t * std::cos(phi), r * t * std::sin(phi), z;
    cloud.normals.row(i) << h * std::cos(phi) / slant, h * std::sin(phi) / slant, (upper ? r : -r) / slant;
  }
  return cloud;
}

TEST(RegionGrowing, BiconeJoinsItsEquator) {
  const double r = 10, h = 15;
  const AnalyticPart bicone = make_bicone(r, h, 0.25);
  const Grown run = triangulate(sample_bicone(r, h, 0.2, 6), 1.0);
  expect_sound(run, "bicone");
  EXPECT_EQ(run.t.components, 1u);
  // The equator is one closed crease on the true circle.
  int equator = 0;
  double worst = 0;
  for (const CreaseLine& line : run.t.crease_lines) {
    if (!line.closed) continue;
    ++equator;
    for (int v : line.vertices) {
      const Vec3 p = vertex(run.t.mesh, v);
      worst = std::max(worst, std::hypot(std::hypot(p.x(), p.y()) - r, p.z() - h));
    }
  }
  EXPECT_EQ(equator, 1);
  std::printf("    equator crease points: worst distance from the true circle %.4f mm\n", worst);
  EXPECT_LT(worst, 0.02);
  // Openings, if any, only where B is far too coarse for the surface: around the apexes.
  for (const ScanLoop& loop : run.t.loops)
    for (int v : loop.vertices) {
      const Vec3 p = vertex(run.t.mesh, v);
      EXPECT_LT(std::min(p.z(), 2 * h - p.z()), 6.0) << "an opening away from the apexes at " << p.transpose();
    }
  const FeatureModel model = extract_features(run.t.mesh);
  const double coverage = testing::covered_fraction(bicone, model, 1.5);
  std::printf("    extract_features: %zu curves, equator coverage %.3f\n", model.features.curves.size(), coverage);
  EXPECT_GT(coverage, 0.95);
}

TEST(RegionGrowing, NoisySquareStaysOnePieceWithoutFalseHoles) {
  const PointCloud raw = sample_faces(testing::rectangle(20, 20), 0.25, 0.05, 7);
  const Grown run = triangulate(raw, 1.0);
  expect_sound(run, "noisy square");
  EXPECT_EQ(run.t.components, 1u);
  EXPECT_EQ(loops_of(run.t, LoopKind::outer), 1u);
  EXPECT_EQ(loops_of(run.t, LoopKind::hole), 0u);
}

TEST(RegionGrowing, NoisyCubeIsClosed) {
  const AnalyticPart cube = make_cube(10, 0.5);
  const PointCloud raw = sample_faces(cube.mesh, 0.2, 0.03, 8);
  const Grown run = triangulate(raw, 1.0);
  const TopologyReport topo = expect_sound(run, "noisy cube");
  EXPECT_EQ(run.t.creases, 12u);
  EXPECT_EQ(topo.boundary_edges, 0u);
}

TEST(RegionGrowing, WithoutScannerNormalsAClosedPartFacesOutward) {
  const AnalyticPart cube = make_cube(10, 0.5);
  const PointCloud raw = sample_faces(cube.mesh, 0.2, 0, 4);
  const Grown run = triangulate(raw, 1.0, false);
  double volume = 0;
  for (Eigen::Index f = 0; f < run.t.mesh.faces.rows(); ++f)
    volume += vertex(run.t.mesh, run.t.mesh.faces(f, 0)).dot(vertex(run.t.mesh, run.t.mesh.faces(f, 1)).cross(vertex(run.t.mesh, run.t.mesh.faces(f, 2)))) / 6;
  EXPECT_NEAR(volume, 1000, 1e-6);
}

TEST(RegionGrowing, RandomPointsAndDuplicatesTerminateEdgeManifold) {
  std::mt19937_64 rng(9);
  PointCloud raw;
  const int n = 3000;
  raw.points.resize(n, 3);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) raw.points(i, k) = 10.0 * (rng() >> 11) * 0x1.0p-53;
  raw.normals.resize(0, 3);
  const Grown random = triangulate(raw, 1.0, false);
  expect_sound(random, "random box");

  // Every point four times, and all on one line.
  PointCloud dup;
  dup.points.resize(4 * 500, 3);
  for (int i = 0; i < 2000; ++i) dup.points.row(i) = raw.points.row(i % 500);
  const Grown duplicates = triangulate(dup, 1.0, false);
  expect_sound(duplicates, "duplicates");
  PointCloud line;
  line.points.resize(400, 3);
  for (int i = 0; i < 400; ++i) line.points.row(i) << 0.05 * i, 0.1 * i, 0;
  const Grown collinear = triangulate(line, 1.0, false);
  EXPECT_EQ(collinear.t.mesh.faces.rows(), 0);
}

TEST(RegionGrowing, TwoInterleavedSheetsStayEdgeManifold) {
  PointCloud a = sample_faces(testing::rectangle(15, 15), 0.25, 0.0, 10);
  PointCloud b = sample_faces(testing::rectangle(15, 15), 0.25, 0.0, 11);
  PointCloud raw;
  raw.points.resize(a.points.rows() + b.points.rows(), 3);
  raw.points << a.points, b.points;
  raw.points.bottomRows(b.points.rows()).col(2).array() += 0.3;
  const Grown run = triangulate(raw, 1.0, false);
  expect_sound(run, "interleaved sheets");
}

// For the record, not the suite (run with --gtest_also_run_disabled_tests): a wavy 316 × 316 mm sheet
// thinned to 100k points at B = 1 mm.
TEST(RegionGrowing, DISABLED_ThroughputOn100kThinnedPoints) {
  const double side = 316;
  std::mt19937_64 rng(14);
  const int n = static_cast<int>(side * side / (0.5 * 0.5));
  PointCloud raw;
  raw.points.resize(n, 3);
  raw.normals.resize(n, 3);
  for (int i = 0; i < n; ++i) {
    const double x = side * (rng() >> 11) * 0x1.0p-53, y = side * (rng() >> 11) * 0x1.0p-53;
    raw.points.row(i) << x, y, 2 * std::sin(x / 10) * std::cos(y / 15);
    raw.normals.row(i) = Vec3(-0.2 * std::cos(x / 10) * std::cos(y / 15), 2.0 / 15 * std::sin(x / 10) * std::sin(y / 15), 1)
                             .normalized()
                             .transpose();
  }
  const Grown run = triangulate(raw, 1.0);
  expect_sound(run, "wavy sheet, 100k");
  EXPECT_EQ(run.t.components, 1u);
  EXPECT_EQ(loops_of(run.t, LoopKind::hole), 0u);
}

TEST(RegionGrowing, IsDeterministic) {
  const AnalyticPart cube = make_cube(10, 0.5);
  const PointCloud raw = sample_faces(cube.mesh, 0.2, 0.02, 12);
  const Grown first = triangulate(raw, 1.0), second = triangulate(raw, 1.0);
  EXPECT_EQ(first.t.mesh.faces, second.t.mesh.faces);
  EXPECT_EQ(first.t.mesh.vertices, second.t.mesh.vertices);
}

TEST(RegionGrowing, StopsWhenCancelled) {
  const PointCloud raw = sample_faces(testing::rectangle(40, 40), 0.25, 0, 13);
  RegionGrowingOptions options;
  options.cancel.requested = [] { return true; };
  EXPECT_THROW(triangulate(raw, 0.5, true, options), Cancelled);
}

}  // namespace
}  // namespace cmm::geometry
