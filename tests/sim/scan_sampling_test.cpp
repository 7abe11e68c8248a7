// The raw scan's ways of sampling a part (issue 36): the random sampling as it always was, a scanner's
// grid, a merge's Poisson disk; isotropic noise; partial views in bands; per-view density; exact view offsets.
#include "sim/scan_sampling.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/analytic_parts.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/face_geometry.hpp"
#include "sim/raw_scan.hpp"

namespace cmm::sim {
namespace {

using geometry::Vec3;

constexpr double kDegree = std::numbers::pi / 180;

const geometry::AnalyticPart& cube() {
  static const geometry::AnalyticPart part = geometry::make_cube(40, 2.0);
  return part;
}

// One view with no registration error, looking down at the top face at `incidence_deg` from its normal.
ScanView tilted_view(double incidence_deg) {
  return {Vec3(std::sin(incidence_deg * kDegree), 0, -std::cos(incidence_deg * kDegree))};
}

std::vector<ScanView> exact_views() { return default_views({.rotation_sigma_deg = 0, .translation_sigma_mm = 0}); }

// Non-stray points on the cube's top face (z = 40), per view.
std::vector<long> top_points(const RawScan& scan, std::size_t views) {
  std::vector<long> count(views, 0);
  for (int i = 0; i < scan.cloud.points.rows(); ++i)
    if (!scan.truth.stray[i] && scan.truth.surface_points(i, 2) > 40 - 1e-9) ++count[scan.truth.view[i]];
  return count;
}

bool same_scan(const RawScan& a, const RawScan& b) {
  return a.cloud.points.rows() == b.cloud.points.rows() &&
         std::memcmp(a.cloud.points.data(), b.cloud.points.data(), sizeof(double) * a.cloud.points.size()) == 0 &&
         std::memcmp(a.cloud.normals.data(), b.cloud.normals.data(), sizeof(double) * a.cloud.normals.size()) == 0 &&
         a.truth.view == b.truth.view && a.truth.face == b.truth.face && a.truth.stray == b.truth.stray;
}

// Recorded from the synthesizer before sampling, noise model, coverage and density were options (commit
// 4978ee84): the default random scan of the 40 mm cube at 1 mm spacing, seed 1.
TEST(ScanSampling, RandomIsTheScanItWasBeforeTheOptions) {
  const RawScan scan = synthesize_raw_scan(cube().mesh, {.spacing_mm = 1.0});
  ASSERT_EQ(scan.cloud.points.rows(), 27200);
  EXPECT_EQ(std::count(scan.truth.stray.begin(), scan.truth.stray.end(), true), 60);
  EXPECT_EQ(Vec3(scan.cloud.points.row(0)), Vec3(0.7149239608831152, 0.33997147410134065, 39.9929397652448));
  EXPECT_EQ(Vec3(scan.cloud.points.row(27199)), Vec3(38.22656482773696, 38.298409811335226, 40.06035758650367));
  double checksum = 0;
  for (int i = 0; i < scan.cloud.points.rows(); ++i)
    checksum += scan.cloud.points(i, 0) + 2 * scan.cloud.points(i, 1) + 3 * scan.cloud.points(i, 2);
  EXPECT_NEAR(checksum, 3935018.84129335, 1e-6);
}

TEST(ScanSampling, EverySamplingIsTheSameScanForTheSameSeedAndAnotherForAnother) {
  for (ScanSampling sampling : {ScanSampling::random, ScanSampling::grid, ScanSampling::poisson}) {
    RawScanOptions options{.spacing_mm = 1.5,
                           .views = views_with_offset(3, 0.02, 5),
                           .sampling = sampling,
                           .noise_model = ScanNoise::isotropic,
                           .view_coverage = 0.8};
    const RawScan a = synthesize_raw_scan(cube().mesh, options), b = synthesize_raw_scan(cube().mesh, options);
    ASSERT_GT(a.cloud.points.rows(), 1000) << to_string(sampling);
    EXPECT_TRUE(same_scan(a, b)) << to_string(sampling);
    options.seed = 2;
    EXPECT_FALSE(same_scan(a, synthesize_raw_scan(cube().mesh, options))) << to_string(sampling);
  }
}

// A raster of pitch s across the image puts cos θ / s² points per mm² on a face at incidence θ.
TEST(ScanSampling, GridDensityFallsWithTheCosineOfTheIncidence) {
  const double spacing = 0.25;
  for (double incidence : {0.0, 30.0, 60.0}) {
    const RawScan scan = synthesize_raw_scan(cube().mesh, {.spacing_mm = spacing,
                                                           .noise_sigma_mm = 0,
                                                           .views = {tilted_view(incidence)},
                                                           .stray_fraction = 0,
                                                           .sampling = ScanSampling::grid});
    const double expected = 40 * 40 * std::cos(incidence * kDegree) / (spacing * spacing);
    const long got = top_points(scan, 1)[0];
    std::printf("grid at %.0f° incidence: %ld points on the top face, cos θ / s² predicts %.0f\n", incidence, got, expected);
    EXPECT_NEAR(got, expected, 0.02 * expected) << incidence << "°";
  }
}

// A face shared edge by edge with its neighbours: no lattice point on a shared edge lands twice.
TEST(ScanSampling, GridPointsAreDistinct) {
  const RawScan scan = synthesize_raw_scan(cube().mesh, {.spacing_mm = 0.5,
                                                         .noise_sigma_mm = 0,
                                                         .views = {{Vec3(0, 0, -1)}},
                                                         .stray_fraction = 0,
                                                         .sampling = ScanSampling::grid});
  const geometry::CloudIndex index(scan.truth.surface_points);
  for (int i = 0; i < scan.truth.surface_points.rows(); ++i) {
    const std::vector<int> two = index.nearest(scan.truth.surface_points.row(i).transpose(), 2);
    ASSERT_GT((scan.truth.surface_points.row(two[0]) - scan.truth.surface_points.row(two[1])).norm(), 0.49) << i;
  }
}

// No two points nearer than the radius, whichever views they came from; about 1 / spacing² on a face.
TEST(ScanSampling, PoissonKeepsItsRadiusAndTheAskedDensity) {
  const double spacing = 0.5, radius = kPoissonRadius * spacing;
  const RawScan scan = synthesize_raw_scan(
      cube().mesh,
      {.spacing_mm = spacing, .noise_sigma_mm = 0, .views = exact_views(), .stray_fraction = 0, .sampling = ScanSampling::poisson});
  const geometry::CloudIndex index(scan.truth.surface_points);
  double nearest = 1e9, mean_nearest = 0;
  for (int i = 0; i < scan.truth.surface_points.rows(); ++i) {
    std::vector<int> ids;
    std::vector<double> squared;
    index.nearest(scan.truth.surface_points.row(i).transpose(), 2, ids, squared);
    nearest = std::min(nearest, std::sqrt(squared[1]));
    mean_nearest += std::sqrt(squared[1]) / static_cast<double>(scan.truth.surface_points.rows());
  }
  const std::vector<long> top = top_points(scan, 7);
  const double density = std::accumulate(top.begin(), top.end(), 0L) / (40.0 * 40.0) * spacing * spacing;
  std::printf("poisson: %ld points, nearest neighbours %.4f mm at the least (radius %.4f), %.4f on average; "
              "%.3f points per spacing² on the top face\n",
              static_cast<long>(scan.cloud.points.rows()), nearest, radius, mean_nearest, density);
  EXPECT_GE(nearest, radius);
  EXPECT_NEAR(density, 1.0, 0.05);
  // Every view that sees the top face got a share of it: each point is credited to one view that sees it.
  for (int v = 0; v < 7; ++v) EXPECT_GT(top[v], 0) << "view " << v;
}

TEST(ScanSampling, IsotropicNoiseHasSigmaInEveryDirection) {
  const RawScan scan = synthesize_raw_scan(cube().mesh, {.spacing_mm = 0.5,
                                                         .noise_sigma_mm = 0.05,
                                                         .views = exact_views(),
                                                         .stray_fraction = 0,
                                                         .noise_model = ScanNoise::isotropic});
  const geometry::FaceGeometry faces = geometry::face_geometry(cube().mesh);
  Vec3 squares = Vec3::Zero();
  double off_surface = 0;
  const long n = scan.cloud.points.rows();
  for (int i = 0; i < n; ++i) {
    const Vec3 offset = (scan.cloud.points.row(i) - scan.truth.surface_points.row(i)).transpose();
    squares += offset.cwiseProduct(offset);
    const double along_normal = offset.dot(faces.normals.row(scan.truth.face[i]));
    off_surface += along_normal * along_normal;
  }
  const Vec3 sigma = (squares / static_cast<double>(n)).cwiseSqrt();
  std::printf("isotropic noise: σ x %.5f, y %.5f, z %.5f, off the surface %.5f mm over %ld points\n", sigma.x(), sigma.y(),
              sigma.z(), std::sqrt(off_surface / n), n);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(sigma[k], 0.05, 0.0015) << "axis " << k;
  EXPECT_NEAR(std::sqrt(off_surface / n), 0.05, 0.0015);
}

// A partial view keeps one band of what it sees: all its points on one side of a plane across its
// image, about the asked share of them, and the views' bands differ, so they overlap in bands.
TEST(ScanSampling, ViewCoverageKeepsBandsOfTheAskedShare) {
  const std::vector<ScanView> views = exact_views();
  for (ScanSampling sampling : {ScanSampling::random, ScanSampling::grid}) {
    RawScanOptions options{.spacing_mm = 0.5, .noise_sigma_mm = 0, .views = views, .stray_fraction = 0, .sampling = sampling};
    const RawScan whole = synthesize_raw_scan(cube().mesh, options);
    options.view_coverage = 0.7;
    const RawScan part = synthesize_raw_scan(cube().mesh, options);
    ASSERT_EQ(part.truth.coverage.size(), views.size());
    std::vector<long> whole_count(views.size(), 0), part_count(views.size(), 0);
    for (int i = 0; i < whole.cloud.points.rows(); ++i) ++whole_count[whole.truth.view[i]];
    for (int i = 0; i < part.cloud.points.rows(); ++i) {
      const CoverageBand& band = part.truth.coverage[part.truth.view[i]];
      ASSERT_TRUE(band.keeps(part.truth.surface_points.row(i).transpose())) << i;
      ++part_count[part.truth.view[i]];
    }
    for (std::size_t v = 0; v < views.size(); ++v) {
      const CoverageBand& band = part.truth.coverage[v];
      EXPECT_NEAR(band.direction.norm(), 1, 1e-12);
      EXPECT_NEAR(band.direction.dot(views[v].direction), 0, 1e-12) << "across the image";
      const double share = static_cast<double>(part_count[v]) / static_cast<double>(whole_count[v]);
      std::printf("%s, view %zu: %ld of %ld points kept (%.3f)\n", to_string(sampling), v, part_count[v], whole_count[v], share);
      EXPECT_NEAR(share, 0.7, 0.03) << to_string(sampling) << " view " << v;
    }
    EXPECT_GT((part.truth.coverage[0].direction - part.truth.coverage[6].direction).norm(), 1e-3);
  }
}

TEST(ScanSampling, ViewDensityScalesEachViewsPoints) {
  const std::vector<ScanView> views = {tilted_view(0), tilted_view(30)};
  for (ScanSampling sampling : {ScanSampling::random, ScanSampling::grid}) {
    RawScanOptions options{.spacing_mm = 0.5, .noise_sigma_mm = 0, .views = views, .stray_fraction = 0, .sampling = sampling};
    const std::vector<long> even = top_points(synthesize_raw_scan(cube().mesh, options), 2);
    options.view_density = {1, 4};
    const std::vector<long> dense = top_points(synthesize_raw_scan(cube().mesh, options), 2);
    EXPECT_NEAR(dense[0], even[0], 0.02 * even[0]) << to_string(sampling);
    EXPECT_NEAR(dense[1], 4 * even[1], 0.02 * 4 * even[1]) << to_string(sampling);
  }
}

TEST(ScanSampling, ViewOffsetIsExactlyTheAskedTranslation) {
  const std::vector<ScanView> views = views_with_offset(4, 0.015, 9);
  ASSERT_EQ(views.size(), 4u);
  EXPECT_EQ(views.back().direction, Vec3(0, 0, -1));  // the view from above is kept
  const std::vector<ScanView> spread = default_views({.around = 3});
  for (std::size_t v = 0; v < views.size(); ++v) {
    EXPECT_EQ(views[v].direction, spread[v].direction);
    EXPECT_TRUE(views[v].registration_error.linear().isIdentity(0)) << v;
    EXPECT_NEAR(views[v].registration_error.translation().norm(), 0.015, 1e-15) << v;
  }
  EXPECT_GT((views[0].registration_error.translation() - views[1].registration_error.translation()).norm(), 1e-4);
  EXPECT_EQ(views_with_offset(1, 0.1, 3).size(), 1u);
  EXPECT_THROW(views_with_offset(0, 0.1, 3), std::invalid_argument);
  EXPECT_THROW(views_with_offset(3, -0.1, 3), std::invalid_argument);

  const RawScan scan = synthesize_raw_scan(cube().mesh, {.spacing_mm = 2, .noise_sigma_mm = 0, .views = views, .stray_fraction = 0});
  ASSERT_GT(scan.cloud.points.rows(), 0);
  for (int i = 0; i < scan.cloud.points.rows(); ++i) {
    const Vec3 moved = (scan.cloud.points.row(i) - scan.truth.surface_points.row(i)).transpose();
    ASSERT_LT((moved - views[scan.truth.view[i]].registration_error.translation()).norm(), 1e-12) << i;
  }
}

TEST(ScanSampling, BadOptionsNameTheOption) {
  auto message = [&](const RawScanOptions& options) {
    try {
      synthesize_raw_scan(cube().mesh, options);
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("no throw");
  };
  EXPECT_NE(message({.view_coverage = 0}).find("view_coverage"), std::string::npos);
  EXPECT_NE(message({.view_coverage = 1.5}).find("view_coverage"), std::string::npos);
  EXPECT_NE(message({.view_density = {1, 2}}).find("view_density"), std::string::npos);
  EXPECT_NE(message({.view_density = std::vector<double>(7, 0.0)}).find("view_density"), std::string::npos);
  EXPECT_NE(message({.sampling = static_cast<ScanSampling>(7)}).find("sampling"), std::string::npos);
  EXPECT_NE(message({.noise_model = static_cast<ScanNoise>(7)}).find("noise_model"), std::string::npos);
  // Work no request may ask for: a density factor of 1e300 or a spacing of 1 nm is refused, not overflowed.
  EXPECT_NE(message({.view_density = {1e300, 1, 1, 1, 1, 1, 1}}).find("a synthesized scan may draw"), std::string::npos);
  EXPECT_NE(message({.spacing_mm = 1e-6}).find("a synthesized scan may draw"), std::string::npos);
}

}  // namespace
}  // namespace cmm::sim
