// The plate's small true openings (a Ø3 hole and a 2 mm slot, rims of a few bins' radius) in the scans
// the matrix makes: merged random views and partial views of different density, each view offset by
// 0.02 mm. A crease taken across a rim that curves that fast splits the bore's wall into planes (a
// "corner" every few bins), fits one plane through a thin band of it (tilted 20° off the wall), or runs
// a slot's straight side on into its end's half circle, and the chords meet inside the opening: crease
// points up to 0.34 mm over the mouth, the top face grown over them, and on the matrix's partial views
// (seed 1) a fold into the Ø3 hole's wall that tore the plate's top open to its back edge (refused now: a
// facet grown inside out). The goal: no vertex of the mesh more than half a bin over either mouth. These
// four scans had 6, 5, 5 and 2 on b8f140d (up to 0.34 mm inside), and have 6, 3, 2 and 2; disabled until
// it holds (docs/scan.md, "Rims of a few bins' radius", says what was tried).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "geometry/analytic_parts.hpp"
#include "geometry/scan_front_end.hpp"
#include "sim/raw_scan.hpp"
#include "sim/scan_views.hpp"

namespace cmm {
namespace {

// How far (x, y) lies inside the Ø3 hole at (10, 70) or the slot (half circles of radius 1 centred at
// (36, 10) and (44, 10)); negative outside both.
double inside_small_openings(double x, double y) {
  const double hole = 1.5 - std::hypot(x - 10, y - 70);
  const double slot = 1 - std::hypot(x - std::clamp(x, 36.0, 44.0), y - 10);
  return std::max(hole, slot);
}

struct Mouths {
  int points_in = 0, vertices_over = 0;
  double deepest_mm = 0;
};

// The scan near the two openings only (within 5 mm of their outlines), meshed at ε 0.1 mm.
Mouths vertices_over_mouths(bool partial_views, std::uint64_t seed) {
  const geometry::TriangleMesh scene = geometry::make_plate_small_openings(0.25).mesh;
  sim::RawScanOptions options;
  options.spacing_mm = 0.25;
  options.noise_sigma_mm = 0;
  options.stray_fraction = 0.005;
  options.seed = seed;
  options.views = sim::views_with_offset(5, 0.02, seed);
  options.sampling = sim::ScanSampling::random;
  options.noise_model = sim::ScanNoise::isotropic;
  if (partial_views) {
    options.view_coverage = 0.8;
    options.view_density = {1.0, 0.4, 2.0, 0.7, 1.5};
  }
  const sim::RawScan raw = sim::synthesize_raw_scan(scene, options);
  geometry::PointCloud near;
  std::vector<Eigen::Index> kept;
  for (Eigen::Index i = 0; i < raw.cloud.points.rows(); ++i)
    if (inside_small_openings(raw.cloud.points(i, 0), raw.cloud.points(i, 1)) > -5) kept.push_back(i);
  near.points.resize(static_cast<Eigen::Index>(kept.size()), 3);
  near.normals.resize(static_cast<Eigen::Index>(kept.size()), 3);
  for (std::size_t k = 0; k < kept.size(); ++k) {
    near.points.row(static_cast<Eigen::Index>(k)) = raw.cloud.points.row(kept[k]);
    near.normals.row(static_cast<Eigen::Index>(k)) = raw.cloud.normals.row(kept[k]);
  }
  geometry::ScanOptions front;
  front.tolerance_mm = 0.1;
  const geometry::ScanMesh meshed = geometry::mesh_scan(near, "plate near its small openings", front);
  Mouths m;
  m.points_in = static_cast<int>(kept.size());
  for (Eigen::Index v = 0; v < meshed.mesh.vertices.rows(); ++v) {
    const geometry::Vec3 x = geometry::vertex(meshed.mesh, v);
    if (x.z() < 9.5) continue;
    const double inside = inside_small_openings(x.x(), x.y());
    m.deepest_mm = std::max(m.deepest_mm, inside);
    // Half a bin: a chord of the rim between two of its points lies about 0.06 mm inside.
    if (inside > 0.15) ++m.vertices_over;
  }
  return m;
}

TEST(RawScanSmallOpenings, DISABLED_NoVertexOverTheMouthOfAnOpeningAFewBinsWide) {
  for (const bool partial : {false, true})
    for (const std::uint64_t seed : {1, 2}) {
      const Mouths m = vertices_over_mouths(partial, seed);
      std::printf("%s, seed %d: %d points, %d vertices over a mouth, deepest %.3f mm inside\n",
                  partial ? "partial views" : "random views", static_cast<int>(seed), m.points_in, m.vertices_over,
                  m.deepest_mm);
      EXPECT_EQ(m.vertices_over, 0) << (partial ? "partial views" : "random views") << ", seed " << seed << ": deepest "
                                    << m.deepest_mm << " mm inside";
    }
}

}  // namespace
}  // namespace cmm
