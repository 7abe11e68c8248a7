// The synthesized scans against their truth on the analytic parts: what the views see and miss (steep
// faces, bore walls), the beam noise, the strays, the scanned mesh's noise and removed faces, and seeds.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/analytic_parts.hpp"
#include "geometry/face_geometry.hpp"
#include "sim/raw_scan.hpp"
#include "sim/scanned_mesh.hpp"
#include "sim/visibility.hpp"

namespace cmm::sim {
namespace {

using geometry::Vec3;

// Where on the case-3 block a true point lies: the faces the tests name.
enum class Region { top, bottom, outer_wall, small_bore, large_bore };

Region region_of(const Vec3& p, const Vec3& normal) {
  if (normal.z() > 0.99) return Region::top;
  if (normal.z() < -0.99) return Region::bottom;
  // Ø10 bores at (13|75, 12.5|82.5), the Ø42 bore at (44, 47.5); everything else vertical is outside.
  for (const Vec3& axis : {Vec3(13, 12.5, 0), Vec3(75, 12.5, 0), Vec3(13, 82.5, 0), Vec3(75, 82.5, 0)})
    if (std::hypot(p.x() - axis.x(), p.y() - axis.y()) < 5.01) return Region::small_bore;
  if (std::hypot(p.x() - 44, p.y() - 47.5) < 21.01) return Region::large_bore;
  return Region::outer_wall;
}

// The views with no registration error, so that a point's offset from its truth is the beam noise alone.
std::vector<ScanView> exact_views() { return default_views({.rotation_sigma_deg = 0, .translation_sigma_mm = 0}); }

// One raw scan of the case-3 block at 1 mm edges and 1 mm spacing, shared by the tests that only read it.
struct Case3 {
  geometry::AnalyticPart part = geometry::make_case3_block(1.0);
  geometry::FaceGeometry faces = geometry::face_geometry(part.mesh);
  RawScan scan = synthesize_raw_scan(part.mesh, {.spacing_mm = 1.0, .views = exact_views()});
  Region region(int face) const { return region_of(geometry::face_centroid(part.mesh, face), faces.normals.row(face)); }
};

const Case3& case3() {
  static const Case3 c;
  return c;
}

// A view at elevation e sees a Ø10 bore's wall at most D·tan(e) deep: below that its beams hit the wall
// across. The deep walls (here 41 − 11.9 mm of them) are what a scanner misses.
constexpr double kSmallBoreSeenDepth = 10 * 1.19175359;  // tan 50°

TEST(RawScan, SeesTheTopFaceAndOnlyTheMouthsOfTheBores) {
  const Case3& c = case3();
  std::array<int, 5> count{};
  double deepest_small_bore = 0;
  for (int i = 0; i < c.scan.cloud.points.rows(); ++i) {
    if (c.scan.truth.stray[i]) continue;
    const Region r = c.region(c.scan.truth.face[i]);
    ++count[static_cast<int>(r)];
    if (r == Region::small_bore) deepest_small_bore = std::max(deepest_small_bore, 41 - c.scan.truth.surface_points(i, 2));
  }
  std::printf("raw scan (1 mm): %ld points; top %d, bottom %d, outer walls %d, Ø10 bores %d (deepest %.2f mm), "
              "Ø42 bore %d\n",
              static_cast<long>(c.scan.cloud.points.rows()), count[0], count[1], count[2], count[3], deepest_small_bore,
              count[4]);
  // The top face (≈ 6660 mm²) is seen head-on by the view from above and at 50° by the six around.
  EXPECT_GT(count[static_cast<int>(Region::top)], 6 * 6660);
  EXPECT_EQ(count[static_cast<int>(Region::bottom)], 0);
  EXPECT_GT(count[static_cast<int>(Region::outer_wall)], 1000);
  EXPECT_LE(deepest_small_bore, kSmallBoreSeenDepth + 1e-6);
}

TEST(RawScan, BeamNoiseHasTheAskedSigma) {
  const Case3& c = case3();
  const std::vector<ScanView> views = exact_views();
  double beam_sum = 0, beam_squares = 0, normal_squares = 0, across = 0;
  long n = 0, top_n = 0;
  for (int i = 0; i < c.scan.cloud.points.rows(); ++i) {
    if (c.scan.truth.stray[i]) continue;
    const Vec3 offset = (c.scan.cloud.points.row(i) - c.scan.truth.surface_points.row(i)).transpose();
    const Vec3 beam = views[c.scan.truth.view[i]].direction;
    const double e = offset.dot(beam);
    beam_sum += e;
    beam_squares += e * e;
    across = std::max(across, (offset - e * beam).norm());
    ++n;
    // Along the true normal: from straight above onto the top face the beam is the normal.
    if (c.scan.truth.view[i] == 6 && c.region(c.scan.truth.face[i]) == Region::top) {
      const double along_normal = offset.dot(c.faces.normals.row(c.scan.truth.face[i]));
      normal_squares += along_normal * along_normal;
      ++top_n;
    }
  }
  const double beam_sigma = std::sqrt(beam_squares / n), normal_sigma = std::sqrt(normal_squares / top_n);
  std::printf("beam noise: σ %.5f mm over %ld points (mean %.2e); along the top face's normal %.5f mm over %ld\n",
              beam_sigma, n, beam_sum / n, normal_sigma, top_n);
  EXPECT_NEAR(beam_sigma, 0.05, 0.005);
  EXPECT_NEAR(normal_sigma, 0.05, 0.005);
  EXPECT_NEAR(beam_sum / n, 0, 5 * 0.05 / std::sqrt(n));
  EXPECT_LT(across, 1e-9);  // noise only along the beam
}

TEST(RawScan, StrayFractionWithinBinomialBounds) {
  const Case3& c = case3();
  const long n = c.scan.cloud.points.rows();
  const long strays = std::count(c.scan.truth.stray.begin(), c.scan.truth.stray.end(), true);
  const double p = 0.002, bound = 4 * std::sqrt(n * p * (1 - p));
  std::printf("strays: %ld of %ld (%.4f %%), expected %.1f ± %.1f (4σ)\n", strays, n, 100.0 * strays / n, n * p, bound);
  EXPECT_NEAR(strays, n * p, bound);
  const Vec3 lo(-4.4, -4.75, -2.05), hi(92.4, 99.75, 43.05);  // the block's box grown by 10 %
  for (int i = 0; i < n; ++i) {
    if (!c.scan.truth.stray[i]) continue;
    EXPECT_EQ(c.scan.truth.face[i], -1);
    const Vec3 p = c.scan.cloud.points.row(i);
    EXPECT_TRUE((p.array() >= lo.array() - 1e-9).all() && (p.array() <= hi.array() + 1e-9).all()) << p.transpose();
  }
}

TEST(RawScan, OuterWallSeenBySideViewsOnly) {
  const Case3& c = case3();
  // The wall x = 88 faces +x: view 0 (from +x) sees it at 50°; views 2–4 face away, view 6 grazes it.
  std::vector<int> per_view(7, 0);
  for (int i = 0; i < c.scan.cloud.points.rows(); ++i)
    if (!c.scan.truth.stray[i] && c.faces.normals(c.scan.truth.face[i], 0) > 0.99 &&
        c.scan.truth.surface_points(i, 0) > 87.99)
      ++per_view[c.scan.truth.view[i]];
  EXPECT_GT(per_view[0], 0.9 * 95 * 41);  // area / spacing² = 3895 expected, all of it in view
  EXPECT_GT(per_view[1], 0);              // 60° around: incidence ≈ 71°, still below 75°
  for (int v : {2, 3, 4, 6}) EXPECT_EQ(per_view[v], 0) << "view " << v;
}

TEST(RawScan, ViewRegistrationErrorMovesEachViewRigidly) {
  const geometry::AnalyticPart cube = geometry::make_cube(40, 2.0);
  RawScanOptions options{.spacing_mm = 2.0, .noise_sigma_mm = 0, .stray_fraction = 0};
  options.views = default_views({.rotation_sigma_deg = 0.05, .translation_sigma_mm = 0.05, .seed = 3});
  const RawScan scan = synthesize_raw_scan(cube.mesh, options);
  ASSERT_GT(scan.cloud.points.rows(), 0);
  for (int i = 0; i < scan.cloud.points.rows(); ++i) {
    const Eigen::Isometry3d& error = options.views[scan.truth.view[i]].registration_error;
    const Vec3 expected = error * Vec3(scan.truth.surface_points.row(i));
    ASSERT_LT((Vec3(scan.cloud.points.row(i)) - expected).norm(), 1e-12);
  }
}

TEST(RawScan, SameSeedSameScanOtherSeedOther) {
  const geometry::AnalyticPart cube = geometry::make_cube(40, 2.0);
  const RawScanOptions options{.spacing_mm = 1.0};
  const RawScan a = synthesize_raw_scan(cube.mesh, options), b = synthesize_raw_scan(cube.mesh, options);
  ASSERT_EQ(a.cloud.points.rows(), b.cloud.points.rows());
  EXPECT_EQ(std::memcmp(a.cloud.points.data(), b.cloud.points.data(), sizeof(double) * a.cloud.points.size()), 0);
  EXPECT_EQ(std::memcmp(a.cloud.normals.data(), b.cloud.normals.data(), sizeof(double) * a.cloud.normals.size()), 0);
  EXPECT_EQ(a.truth.view, b.truth.view);
  EXPECT_EQ(a.truth.stray, b.truth.stray);
  RawScanOptions other = options;
  other.seed = 2;
  const RawScan c = synthesize_raw_scan(cube.mesh, other);
  EXPECT_FALSE(c.cloud.points.rows() == a.cloud.points.rows() && c.cloud.points == a.cloud.points);
}

TEST(RawScan, BadOptionsNameTheOption) {
  const geometry::AnalyticPart cube = geometry::make_cube(40, 4.0);
  auto message = [&](const RawScanOptions& options) {
    try {
      synthesize_raw_scan(cube.mesh, options);
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("no throw");
  };
  EXPECT_NE(message({.spacing_mm = 0}).find("spacing_mm"), std::string::npos);
  EXPECT_NE(message({.spacing_mm = -1}).find("spacing_mm"), std::string::npos);
  EXPECT_NE(message({.noise_sigma_mm = std::nan("")}).find("noise_sigma_mm"), std::string::npos);
  EXPECT_NE(message({.views = {}}).find("views"), std::string::npos);
  EXPECT_NE(message({.views = {{Vec3(0, 0, -2)}}}).find("views"), std::string::npos);
  EXPECT_NE(message({.max_incidence_deg = 90}).find("max_incidence_deg"), std::string::npos);
  EXPECT_NE(message({.stray_fraction = 1}).find("stray_fraction"), std::string::npos);
  EXPECT_THROW(default_views({.around = 0, .from_above = false}), std::invalid_argument);
}

TEST(Visibility, OccluderHidesWhatIsBehindIt) {
  // Two squares 10 mm apart along z, the upper one smaller: from above it hides the middle of the lower.
  geometry::TriangleMesh scene;
  scene.vertices.resize(8, 3);
  scene.vertices << 0, 0, 0, 10, 0, 0, 10, 10, 0, 0, 10, 0, 3, 3, 10, 7, 3, 10, 7, 7, 10, 3, 7, 10;
  scene.faces.resize(4, 3);
  scene.faces << 0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7;
  const ScanVisibility visibility(scene);
  const Vec3 down(0, 0, -1);
  EXPECT_TRUE(visibility.sees(Vec3(1, 1, 0), 0, down));
  EXPECT_FALSE(visibility.sees(Vec3(5, 4, 0), 0, down));
  EXPECT_FALSE(visibility.sees(Vec3(7, 7, 0), 1, down));  // exactly under the occluder's corner: still hidden
  EXPECT_TRUE(visibility.sees(Vec3(5, 5, 10), 2, down));
  // 20° off vertical toward +x the beams back rise toward −x, 3.64 mm per 10 mm of height.
  const Vec3 slanted(std::sin(0.349066), 0, -std::cos(0.349066));
  EXPECT_TRUE(visibility.sees(Vec3(9, 5, 0), 0, down));
  EXPECT_FALSE(visibility.sees(Vec3(9, 5, 0), 0, slanted));  // its beam crosses z = 10 at x = 5.36
  EXPECT_TRUE(visibility.sees(Vec3(5, 5, 0), 0, slanted));   // at x = 1.36, beside the occluder
  EXPECT_FALSE(visibility.facing(0, Vec3(0, 0, 1)));         // seen from below the floor faces away
  EXPECT_FALSE(visibility.facing(0, Vec3(std::sin(1.35), 0, -std::cos(1.35))));  // 77° incidence: too steep
  EXPECT_TRUE(visibility.facing(0, Vec3(std::sin(1.25), 0, -std::cos(1.25))));   // 72°
}

TEST(ScannedMesh, DropsTheDeepBoreWallsAndKeepsTheTop) {
  const Case3& c = case3();
  const ScannedMesh scanned = synthesize_scanned_mesh(c.part.mesh, {.views = exact_views()});
  std::array<int, 5> removed{}, total{};
  for (int f = 0; f < c.part.mesh.faces.rows(); ++f) ++total[static_cast<int>(c.region(f))];
  for (int f : scanned.removed_faces) ++removed[static_cast<int>(c.region(f))];
  int deep_small_bore_kept = 0, deep_small_bore = 0;
  std::vector<bool> is_removed(c.part.mesh.faces.rows(), false);
  for (int f : scanned.removed_faces) is_removed[f] = true;
  for (int f = 0; f < c.part.mesh.faces.rows(); ++f)
    if (c.region(f) == Region::small_bore && 41 - geometry::face_centroid(c.part.mesh, f).z() > kSmallBoreSeenDepth) {
      ++deep_small_bore;
      deep_small_bore_kept += !is_removed[f];
    }
  std::printf("scanned mesh: %ld of %ld faces kept; removed: top %d/%d, bottom %d/%d, outer %d/%d, Ø10 bores %d/%d "
              "(deeper than %.1f mm: %d of %d kept), Ø42 bore %d/%d\n",
              static_cast<long>(scanned.mesh.faces.rows()), static_cast<long>(c.part.mesh.faces.rows()), removed[0],
              total[0], removed[1], total[1], removed[2], total[2], removed[3], total[3], kSmallBoreSeenDepth,
              deep_small_bore_kept, deep_small_bore, removed[4], total[4]);
  EXPECT_EQ(removed[static_cast<int>(Region::top)], 0);
  EXPECT_EQ(removed[static_cast<int>(Region::bottom)], total[static_cast<int>(Region::bottom)]);
  EXPECT_EQ(removed[static_cast<int>(Region::outer_wall)], 0);
  EXPECT_GT(deep_small_bore, 0);
  EXPECT_EQ(deep_small_bore_kept, 0);
  EXPECT_EQ(static_cast<long>(scanned.mesh.faces.rows() + scanned.removed_faces.size()), c.part.mesh.faces.rows());

  // Every output vertex is a noisy copy of its true vertex, σ per coordinate; every one is used.
  ASSERT_EQ(static_cast<long>(scanned.true_vertex.size()), scanned.mesh.vertices.rows());
  std::vector<bool> used(scanned.mesh.vertices.rows(), false);
  for (int k = 0; k < scanned.mesh.faces.size(); ++k) used[scanned.mesh.faces.data()[k]] = true;
  EXPECT_TRUE(std::all_of(used.begin(), used.end(), [](bool u) { return u; }));
  double squares = 0;
  for (int v = 0; v < scanned.mesh.vertices.rows(); ++v)
    squares += (scanned.mesh.vertices.row(v) - c.part.mesh.vertices.row(scanned.true_vertex[v])).squaredNorm();
  const double rms = std::sqrt(squares / (3.0 * scanned.mesh.vertices.rows()));
  std::printf("scanned mesh vertex noise: RMS %.5f mm per coordinate over %ld vertices\n", rms,
              static_cast<long>(scanned.mesh.vertices.rows()));
  EXPECT_NEAR(rms, 0.05, 0.0025);
}

TEST(ScannedMesh, SameSeedSameMeshOtherSeedOther) {
  const geometry::AnalyticPart plate = geometry::make_plate_with_holes(2.0);
  const ScannedMesh a = synthesize_scanned_mesh(plate.mesh, {}), b = synthesize_scanned_mesh(plate.mesh, {});
  ASSERT_EQ(a.mesh.vertices.rows(), b.mesh.vertices.rows());
  EXPECT_EQ(std::memcmp(a.mesh.vertices.data(), b.mesh.vertices.data(), sizeof(double) * a.mesh.vertices.size()), 0);
  EXPECT_EQ(a.mesh.faces, b.mesh.faces);
  EXPECT_EQ(a.true_vertex, b.true_vertex);
  EXPECT_EQ(a.removed_faces, b.removed_faces);
  const ScannedMesh c = synthesize_scanned_mesh(plate.mesh, {.seed = 2});
  EXPECT_EQ(c.mesh.faces, a.mesh.faces);  // what is seen does not depend on the seed
  EXPECT_NE(c.mesh.vertices, a.mesh.vertices);
}

TEST(ScannedMesh, BadOptionsNameTheOption) {
  const geometry::AnalyticPart cube = geometry::make_cube(40, 4.0);
  EXPECT_THROW(
      {
        try {
          synthesize_scanned_mesh(cube.mesh, {.noise_sigma_mm = std::nan("")});
        } catch (const std::invalid_argument& error) {
          EXPECT_NE(std::string(error.what()).find("noise_sigma_mm"), std::string::npos);
          throw;
        }
      },
      std::invalid_argument);
  EXPECT_THROW(synthesize_scanned_mesh(cube.mesh, {.views = {}}), std::invalid_argument);
}

}  // namespace
}  // namespace cmm::sim
