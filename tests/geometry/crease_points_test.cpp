// Crease points where one face was scanned far more sparsely than the other: the plate's back face in
// merged partial views is seen by one view of five at a grazing angle (about 5 points per mm² beside
// the top's 40), its fits are wider than 3 B and irregular out to their own radius, and the crease along
// the top edge was found nowhere; the growth then left a strip 307 mm round open along it. On three
// draws of such an edge the crease was found along none of it; then along 67–87 %; with each face's raw
// points in the profile (regular or not), 87–96 %.
#include "geometry/crease_points.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <set>

#include "geometry/cloud_index.hpp"
#include "geometry/local_surface.hpp"

namespace cmm::geometry {
namespace {

constexpr double kLength = 30;  // along y
constexpr double kBin = 0.31;   // the bin the matrix's ε 0.1 mm gives on that plate scan

// The top face z = 0 (x from −10 to 0) at `top_density` points per mm², the side face x = 0 (z from −10
// to 0) at `side_density`, both with isotropic noise σ.
Points right_angle(double top_density, double side_density, double sigma, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> across(-10, 0), along(0, kLength);
  std::normal_distribution<double> noise(0, sigma);
  const auto top = static_cast<Eigen::Index>(top_density * 10 * kLength);
  const auto side = static_cast<Eigen::Index>(side_density * 10 * kLength);
  Points p(top + side, 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    const double u = across(random), y = along(random);
    const Vec3 x = i < top ? Vec3(u, y, 0) : Vec3(0, y, u);
    p.row(i) = (x + Vec3(noise(random), noise(random), noise(random))).transpose();
  }
  return p;
}

struct EdgeFound {
  double share = 0;           // of the edge (y from 2 to 28, in 0.5 mm steps) with a crease point within 0.1 mm
  std::size_t polylines = 0;  // the crease is found in this many pieces (one would do)
};

EdgeFound edge_found(const Points& cloud) {
  const CloudIndex index(cloud);
  const std::vector<LocalSurface> fits = fit_local_surfaces(cloud, index);
  CreaseOptions options;
  options.bin_mm = kBin;
  const Creases creases = find_creases(cloud, fits, index, options);
  std::set<int> steps;
  for (const CreasePoint& c : creases.points) {
    const Vec3& x = c.position;
    if (std::hypot(x.x(), x.z()) <= 0.1 && x.y() >= 2 && x.y() < 28) steps.insert(static_cast<int>((x.y() - 2) / 0.5));
  }
  return {static_cast<double>(steps.size()) / 52, creases.polylines.size()};
}

// Found along 87–96 % in 4–7 pieces when the look beside a flat face went no wider than 3 B and pieces
// were joined across 2.5 B at most; now 98–100 % in one or two.
TEST(CreasePoints, FoundBesideAFaceScannedEightTimesMoreSparsely) {
  for (const std::uint64_t seed : {1, 2, 3}) {
    const EdgeFound found = edge_found(right_angle(40, 5, 0.025, seed));
    std::printf("seed %d: crease found along %.0f %% of the edge in %zu pieces\n", static_cast<int>(seed), 100 * found.share, found.polylines);
    EXPECT_GE(found.share, 0.95) << "seed " << seed;
    EXPECT_LE(found.polylines, 2u) << "seed " << seed;
  }
}

// At 2 points per mm² (a side seen only by a merged scan's sparse view, at 100k points on the plate) the
// side's points within 3 B of the edge are too few to be a face: the crease was found along 0–8 % of the
// edge. Looking beside the top face out to 6 B and joining the pieces on one line across up to 8 B where
// the raw points run along the gap: 79–88 %.
TEST(CreasePoints, FoundBesideAFaceScannedTwentyTimesMoreSparsely) {
  for (const std::uint64_t seed : {1, 2, 3}) {
    const EdgeFound found = edge_found(right_angle(40, 2, 0.025, seed));
    std::printf("seed %d: crease found along %.0f %% of the edge in %zu pieces\n", static_cast<int>(seed), 100 * found.share, found.polylines);
    EXPECT_GE(found.share, 0.75) << "seed " << seed;
  }
}

TEST(CreasePoints, FoundWhereBothFacesAreScannedAlike) {
  EXPECT_GE(edge_found(right_angle(20, 20, 0.025, 1)).share, 0.9);
}

// A curved crease: the bicone r = 10 − |z| (45° faces, the crease a circle of radius 10) sampled at random
// without noise, 50 points per mm², within 2 mm of it. Planes fitted over 2 B of a cone are secants and
// meet inside the crease; the profiles square to it do not. Where only one side had five regular points in
// the profile's band, nothing was refined, and the crease points stood 0.0039 mm inside on average (95 %
// within 0.0065 mm); with that side's plane standing in for its profile, 0.0016 (0.0041); with each side's
// raw points in its profile, regular or not, 0.0002 (0.0003).
TEST(CreasePoints, OnACurvedCreaseWhereOnlyOneSideHasAProfile) {
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> angle(0, 2 * std::numbers::pi), height(-2, 2);
  std::vector<Vec3> kept;
  while (kept.size() < 50 * 2 * 126 * 2) {  // both cones' bands, 2√2 mm wide each, round a 63 mm circle
    const double a = angle(random), z = height(random), r = 10 - std::abs(z);
    kept.emplace_back(r * std::cos(a), r * std::sin(a), z);
  }
  Points cloud(static_cast<Eigen::Index>(kept.size()), 3);
  for (std::size_t i = 0; i < kept.size(); ++i) cloud.row(static_cast<Eigen::Index>(i)) = kept[i].transpose();
  const CloudIndex index(cloud);
  const std::vector<LocalSurface> fits = fit_local_surfaces(cloud, index);
  CreaseOptions options;
  options.bin_mm = 0.35;
  const Creases creases = find_creases(cloud, fits, index, options);
  double sum = 0;
  std::vector<double> off;
  for (const CreasePoint& c : creases.points) {
    const Vec3& x = c.position;
    off.push_back((std::hypot(x.x(), x.y()) + std::abs(x.z()) - 10) / std::sqrt(2.0));
    sum += off.back();
  }
  ASSERT_GT(off.size(), 150u);
  std::sort(off.begin(), off.end(), [](double a, double b) { return std::abs(a) < std::abs(b); });
  const double mean = sum / static_cast<double>(off.size()), p95 = std::abs(off[off.size() * 95 / 100]);
  std::printf("%zu crease points: %.4f mm off the crease on average, 95 %% within %.4f mm\n", off.size(), mean, p95);
  EXPECT_LT(std::abs(mean), 0.001);
  EXPECT_LT(p95, 0.001);
}

// A bore's rim on a grid scan: the top face at 8 points per mm², the wall of a Ø10 bore seen at a grazing
// angle at 1.2 (the case-3 block's grid scan coarsened to 100k points), noise σ 0.05 mm, B 0.74 mm. No fit
// on the wall within 1.5 mm of the rim was regular, and the rim crease was found in 3 of 24 sectors of
// the circle (a crease point within 0.25 mm of the rim), 0.11 mm inside it on average (on the block's
// scan, 0.22): the growth left gaps at the rim that folded patches closed, and the plan called a quarter
// of the rim concave. Now the wall's raw points make the second face beside a flat top, and its trace,
// fitted bent along the rim, takes out most of the secant: 20 of 24 sectors, 0.07 mm inside.
TEST(CreasePoints, AroundABoreWhoseWallIsScannedSevenTimesMoreSparsely) {
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> noise(0, 0.05);
  constexpr double radius = 5, outer = 12, depth = 5;
  std::vector<Vec3> kept;
  const auto top = static_cast<int>(8 * std::numbers::pi * (outer * outer - radius * radius));
  for (int i = 0; i < top; ++i) {
    const double a = 2 * std::numbers::pi * unit(random), r = std::sqrt(radius * radius + unit(random) * (outer * outer - radius * radius));
    kept.emplace_back(r * std::cos(a), r * std::sin(a), 0);
  }
  const auto wall = static_cast<int>(1.2 * 2 * std::numbers::pi * radius * depth);
  for (int i = 0; i < wall; ++i) {
    const double a = 2 * std::numbers::pi * unit(random);
    kept.emplace_back(radius * std::cos(a), radius * std::sin(a), -depth * unit(random));
  }
  Points cloud(static_cast<Eigen::Index>(kept.size()), 3);
  for (std::size_t i = 0; i < kept.size(); ++i)
    cloud.row(static_cast<Eigen::Index>(i)) = (kept[i] + Vec3(noise(random), noise(random), noise(random))).transpose();
  const CloudIndex index(cloud);
  const std::vector<LocalSurface> fits = fit_local_surfaces(cloud, index);
  CreaseOptions options;
  options.bin_mm = 0.74;
  const Creases creases = find_creases(cloud, fits, index, options);
  std::set<int> steps;
  double sum = 0;
  int near = 0;
  for (const CreasePoint& c : creases.points) {
    const Vec3& x = c.position;
    const double off = std::hypot(std::hypot(x.x(), x.y()) - radius, x.z());
    if (off > 0.25) continue;
    steps.insert(static_cast<int>((std::atan2(x.y(), x.x()) + std::numbers::pi) / (2 * std::numbers::pi) * 24) % 24);
    sum += std::hypot(x.x(), x.y()) - radius;
    ++near;
  }
  const double share = static_cast<double>(steps.size()) / 24, mean = near > 0 ? sum / near : 1;
  std::printf("rim crease found along %.0f %% of the circle, %d points %.3f mm off it radially on average\n", 100 * share, near, mean);
  EXPECT_GE(share, 0.75);
  EXPECT_LT(std::abs(mean), 0.1);
}

}  // namespace
}  // namespace cmm::geometry
