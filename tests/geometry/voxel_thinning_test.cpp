// Voxel thinning: one point per occupied bin, the nearest its centre, on any cloud (a 100 m extent at
// 1 µm bins, coordinates of 10⁹ mm); the adaptive bins keep fewer points where the surface is flat.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <random>
#include <tuple>

#include "analytic_clouds.hpp"
#include "geometry/bin_size.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/local_surface.hpp"
#include "geometry/voxel_thinning.hpp"

namespace cmm::geometry {
namespace {

using Cell = std::tuple<long long, long long, long long>;

Cell cell_of(const Points& p, int i, const Eigen::RowVector3d& min, double bin) {
  return {static_cast<long long>(std::floor((p(i, 0) - min(0)) / bin)), static_cast<long long>(std::floor((p(i, 1) - min(1)) / bin)),
          static_cast<long long>(std::floor((p(i, 2) - min(2)) / bin))};
}

TEST(VoxelThinning, OnePointPerOccupiedBinTheNearestItsCentre) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0, 10);
  Points p(5000, 3);
  for (int i = 0; i < p.rows(); ++i) p.row(i) << u(rng), u(rng), 0.3 * u(rng);
  const double bin = 0.7;
  const std::vector<int> kept = thin_uniform(p, bin);
  EXPECT_TRUE(std::is_sorted(kept.begin(), kept.end()));
  const Eigen::RowVector3d min = p.colwise().minCoeff();
  std::map<Cell, int> nearest;  // brute force, ordered map: the reference
  for (int i = 0; i < p.rows(); ++i) {
    const Cell c = cell_of(p, i, min, bin);
    const Eigen::RowVector3d centre = min + bin * Eigen::RowVector3d(std::get<0>(c) + 0.5, std::get<1>(c) + 0.5, std::get<2>(c) + 0.5);
    auto it = nearest.find(c);
    if (it == nearest.end() || (p.row(i) - centre).norm() < (p.row(it->second) - centre).norm()) nearest[c] = i;
  }
  std::vector<int> expected;
  for (const auto& [c, i] : nearest) expected.push_back(i);
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(kept, expected);
  EXPECT_EQ(thin_uniform(p, bin), kept);  // deterministic
}

// 100 m at 1 µm: 10⁸ bins per axis, 10²⁴ in all — a packed 32-bit (or 64-bit) index would wrap and
// merge bins. Each bin here holds two points 0.2 µm apart, one at its centre.
TEST(VoxelThinning, HundredMetresAtOneMicrometreDoesNotOverflow) {
  const double bin = 1e-3;
  const int pairs = 1000;
  Points p(2 * pairs, 3);
  std::mt19937_64 rng(2);
  std::uniform_int_distribution<long long> cell(0, 100'000'000 - 1);  // 100 m in µm bins
  for (int i = 0; i < pairs; ++i) {
    const Eigen::RowVector3d centre = (Eigen::RowVector3d(double(cell(rng)), double(cell(rng)), double(cell(rng))).array() + 0.5) * bin;
    p.row(2 * i) = centre + Eigen::RowVector3d(2e-4, 0, 0);
    p.row(2 * i + 1) = centre;
  }
  // Pin the bounding box's minimum at 0 so the cells above are the thinning's.
  p.row(0) = Eigen::RowVector3d(0, 0, 0);
  p.row(1) = Eigen::RowVector3d(0.5, 0.5, 0.5) * bin;
  const std::vector<int> kept = thin_uniform(p, bin);
  ASSERT_EQ(kept.size(), static_cast<std::size_t>(pairs));
  for (int i = 0; i < pairs; ++i) EXPECT_EQ(kept[static_cast<std::size_t>(i)], 2 * i + 1);
}

TEST(VoxelThinning, HugeCoordinatesAndBinCountsAreHandledOrRefused) {
  const Points grid = clouds::graph_samples([](double x, double y) { return 0.1 * x + 0.05 * y; }, 0, 10, 0, 10, 0.25);
  Points far = grid;
  far.rowwise() += Eigen::RowVector3d(1e9, -1e9, 1e9);
  EXPECT_EQ(thin_uniform(far, 1.0).size(), thin_uniform(grid, 1.0).size());
  Points wide(2, 3);
  wide << 0, 0, 0, 1e15, 0, 0;
  EXPECT_EQ(thin_uniform(wide, 1e-3).size(), 2u);  // 10¹⁸ bins along x: still counted exactly
  EXPECT_THROW(thin_uniform(wide, 1e-5), std::invalid_argument);
  EXPECT_THROW(thin_uniform(grid, 0), std::invalid_argument);
  EXPECT_THROW(thin_uniform(grid, std::nan("")), std::invalid_argument);
  Points bad = grid;
  bad(3, 1) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(thin_uniform(bad, 1.0), std::invalid_argument);
  EXPECT_TRUE(thin_uniform(Points(0, 3), 1.0).empty());
}

// A flat face (x < 0) running smoothly into a cylinder of radius 5 mm (0 ≤ x ≤ 4) at 0.1 mm.
double flat_then_cylinder(double x, double) { return x <= 0 ? 0.0 : 5 - std::sqrt(25 - x * x); }

TEST(VoxelThinning, AdaptiveKeepsFewerPointsOnFlatFacesAndAsManyWhereCurved) {
  const Points p = clouds::graph_samples(flat_then_cylinder, -10, 4, -5, 5, 0.1);
  const CloudIndex index(p);
  const auto fits = fit_local_surfaces(p, index);
  BinSizeOptions bin_options;
  bin_options.tolerance_mm = 0.01;
  const BinSize bin = bin_size_for_tolerance(p, fits, index, bin_options);
  ASSERT_FALSE(bin.capped) << bin.source;
  const std::vector<int> uniform = thin_uniform(p, bin.bin_mm);
  AdaptiveThinningOptions options;
  options.bin_mm = bin.bin_mm;
  options.tolerance_mm = bin_options.tolerance_mm;
  const AdaptiveThinning thinned = thin_adaptive(p, fits, options);
  const std::vector<int>& adaptive = thinned.kept;
  EXPECT_TRUE(std::is_sorted(adaptive.begin(), adaptive.end()));
  EXPECT_EQ(thin_adaptive(p, fits, options).kept, adaptive);
  ASSERT_EQ(thinned.levels.size(), adaptive.size());
  // Each kept point's level: 2 (4·B) far out on the flat face, 0 (B) on the cylinder.
  for (std::size_t i = 0; i < adaptive.size(); ++i) {
    const double x = p(adaptive[i], 0);
    if (x < -4) {
      EXPECT_EQ(thinned.levels[i], 2) << "at x " << x;
    } else if (x > 1) {
      EXPECT_EQ(thinned.levels[i], 0) << "at x " << x;
    }
  }
  auto count = [&](const std::vector<int>& ids, double x0, double x1) {
    return std::count_if(ids.begin(), ids.end(), [&](int i) { return p(i, 0) >= x0 && p(i, 0) < x1; });
  };
  std::cout << "B " << bin.bin_mm << " mm: uniform " << uniform.size() << ", adaptive " << adaptive.size()
            << " points; flat part " << count(uniform, -10, -2) << " → " << count(adaptive, -10, -2) << ", curved part "
            << count(uniform, 1, 4) << " → " << count(adaptive, 1, 4) << "\n";
  EXPECT_LT(adaptive.size(), uniform.size() * 6 / 10);
  // Far from the curve, the flat face is thinned at 4·B: 16 × fewer points (up to the bins' edges).
  EXPECT_LT(count(adaptive, -10, -2) * 10, count(uniform, -10, -2));
  // On the cylinder (k = 0.2 /mm sets B) every bin stays at B.
  EXPECT_NEAR(static_cast<double>(count(adaptive, 1, 4)), static_cast<double>(count(uniform, 1, 4)), 0.05 * count(uniform, 1, 4));
  // Every raw point has a kept point within the coarsest bin's diagonal.
  const Points kept = p(adaptive, Eigen::all);
  const CloudIndex kept_index(kept);
  double farthest = 0;
  for (int i = 0; i < p.rows(); ++i)
    farthest = std::max(farthest, (kept.row(kept_index.nearest(p.row(i).transpose(), 1)[0]) - p.row(i)).norm());
  EXPECT_LE(farthest, 4 * bin.bin_mm * std::sqrt(3.0));
}

}  // namespace
}  // namespace cmm::geometry
