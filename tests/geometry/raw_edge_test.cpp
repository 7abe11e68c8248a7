// Where a scanned face ends, from its raw points: the rank line's estimate against the true edge on
// faces sampled at random and on a grid, with noise, and a rim-only hole's border moved onto it by the
// front end (the thinning alone leaves the border about B/4 inside and the hole that much too large).
#include "geometry/raw_edge.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "geometry/boundary_loops.hpp"
#include "geometry/circle_fit.hpp"
#include "geometry/edge_adjacency.hpp"
#include "geometry/scan_front_end.hpp"

namespace cmm::geometry {
namespace {

constexpr double kBin = 0.34;

// The half plane x ≤ 0 of [−4, 0] × [−6, 6] at `density` points per mm², at random, with isotropic noise.
Points random_half_plane(double density, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> x(-4, 0), y(-6, 6);
  std::normal_distribution<double> noise(0, sigma > 0 ? sigma : 1);
  const auto count = static_cast<Eigen::Index>(density * 48);
  Points p(count, 3);
  for (Eigen::Index i = 0; i < count; ++i) {
    p.row(i) << x(rng), y(rng), 0;
    if (sigma > 0) p.row(i) += Eigen::RowVector3d(noise(rng), noise(rng), noise(rng));
  }
  return p;
}

// Mean and RMS error of the edge estimated from 40 border points B/4 inside it along y.
std::pair<double, double> edge_errors(const Points& raw, double sigma = 0) {
  const CloudIndex index(raw);
  double sum = 0, squares = 0;
  int count = 0;
  for (double y = -4; y <= 4; y += 0.2) {
    const Vec3 at(-0.25 * kBin, y, 0);
    const auto edge = raw_edge(raw, index, at, Vec3::UnitZ(), Vec3::UnitX(), {kBin, sigma, 0.1});
    if (!edge) continue;
    const double error = at.x() + edge->out;
    sum += error, squares += error * error, ++count;
  }
  EXPECT_GE(count, 38);
  return {sum / count, std::sqrt(squares / count)};
}

TEST(RawEdge, FoundWhereAFaceSampledAtRandomEnds) {
  // 25 points per mm²: the plate's Ø6 hole seen by the partial views. In a strip 2 B wide the outermost
  // point lies on average 1/(25 · 2B) = 0.06 mm inside the edge, and where the sampling left a void
  // (up to 0.3 mm deep here) so does the estimate; over a border, no bias.
  double mean = 0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const auto [bias, rms] = edge_errors(random_half_plane(25, 0, seed));
    mean += bias / 3;
    EXPECT_LT(rms, 0.1) << "seed " << seed;
  }
  EXPECT_LT(std::abs(mean), 0.015);
}

TEST(RawEdge, FoundUnderIsotropicNoiseOfAQuarterOfTheTolerance) {
  double mean = 0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) mean += edge_errors(random_half_plane(25, 0.025, seed), 0.025).first / 3;
  EXPECT_LT(std::abs(mean), 0.02);
}

TEST(RawEdge, OnAGridHalfARowBeyondTheLastRow) {
  // Rows every 0.15 mm parallel to the edge, the last 0.1 mm inside it: the edge lies somewhere in the
  // row's gap, and the estimate puts it half a row out.
  Points raw(27 * 81, 3);
  Eigen::Index n = 0;
  for (int i = 0; i < 27; ++i)
    for (int j = 0; j < 81; ++j) raw.row(n++) << -0.1 - 0.15 * i, -6 + 0.15 * j, 0;
  const auto [bias, rms] = edge_errors(raw);
  EXPECT_NEAR(bias, -0.1 + 0.075, 0.015);
  EXPECT_LT(rms, 0.04);
}

// A border on a face that curves: a cylinder of radius 5 mm (the case-3 block's Ø10 bores) bending away
// across the border, with noise σ 0.05 mm; B 0.47 mm and ε 0.05 mm as on its scan, where κB² = 0.044 is
// more than ε/2 and a border moved a bin out would leave the surface. The same face flat is moved at 34 of
// the 41 points: a noise as large as ε makes the quadric bend by more than ε/2 now and then.
TEST(RawEdge, NothingOnAFaceThatCurvesMoreThanTheToleranceAllowsOverABin) {
  constexpr double bin = 0.47, sigma = 0.05, radius = 5;
  for (const bool curved : {false, true}) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> x(-4, 0), y(-6, 6);
    std::normal_distribution<double> noise(0, sigma);
    Points raw(25 * 48, 3);
    for (Eigen::Index i = 0; i < raw.rows(); ++i) {
      const double u = x(rng);
      raw.row(i) << u, y(rng), (curved ? radius - std::sqrt(radius * radius - u * u) : 0) + noise(rng);
    }
    const CloudIndex index(raw);
    int found = 0, asked = 0;
    for (double at_y = -4; at_y <= 4; at_y += 0.2, ++asked)
      found += raw_edge(raw, index, Vec3(-0.25 * bin, at_y, 0), Vec3::UnitZ(), Vec3::UnitX(), {bin, sigma, 0.05}).has_value();
    if (curved)
      EXPECT_LE(found, asked / 10) << "moved on a curved face";
    else
      EXPECT_GE(found, asked * 3 / 4) << "not moved on a flat face";
  }
}

TEST(RawEdge, NothingWhereTooFewPointsLie) {
  Points raw(3, 3);
  raw << -0.1, 0, 0, -0.2, 0.1, 0, -0.3, -0.1, 0;
  const CloudIndex index(raw);
  EXPECT_FALSE(raw_edge(raw, index, Vec3(-0.1, 0, 0), Vec3::UnitZ(), Vec3::UnitX(), {kBin, 0.0, 0.1}));
}

// A 20 × 20 mm face with a Ø6 opening whose wall was never seen, at 25 points per mm² at random.
PointCloud face_with_opening(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-10, 10);
  PointCloud cloud;
  std::vector<Vec3> kept;
  for (int i = 0; i < 25 * 400; ++i) {
    const Vec3 p(u(rng), u(rng), 0);
    if (std::hypot(p.x(), p.y()) > 3) kept.push_back(p);
  }
  cloud.points.resize(static_cast<Eigen::Index>(kept.size()), 3);
  for (std::size_t i = 0; i < kept.size(); ++i) cloud.points.row(static_cast<Eigen::Index>(i)) = kept[i].transpose();
  return cloud;
}

TEST(RawEdge, ARimOnlyHolesBorderLiesOnItsRawEdge) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    ScanOptions options;
    options.tolerance_mm = 0.1;
    options.bin_size_mm = kBin;
    const ScanMesh scan = mesh_scan(face_with_opening(seed), "face with a Ø6 opening", options);
    const EdgeAdjacency adjacency = edge_adjacency(scan.mesh);
    int holes = 0;
    for (const BoundaryLoop& loop : boundary_loops(scan.mesh, adjacency)) {
      if (loop.kind != LoopKind::hole) continue;
      ++holes;
      std::vector<Vec3> rim;
      for (int v : loop.vertices) rim.push_back(vertex(scan.mesh, v));
      const Circle3 circle = fit_circle(rim);
      // Within 1 % (the check the matrix holds a hole to is 2 %); the thinned border alone: 2–3 % large.
      EXPECT_NEAR(circle.radius, 3, 0.03) << "seed " << seed;
      EXPECT_LT(circle.centre.head<2>().norm(), 0.05) << "seed " << seed;
    }
    EXPECT_EQ(holes, 1) << "seed " << seed;
  }
}

}  // namespace
}  // namespace cmm::geometry
