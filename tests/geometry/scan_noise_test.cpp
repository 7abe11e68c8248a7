// The scan's noise σ from the local fits' residuals, on noisy planes and spheres of known σ.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "analytic_clouds.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/local_surface.hpp"
#include "geometry/scan_noise.hpp"

namespace cmm::geometry {
namespace {

double noise_of(const Points& p) {
  const CloudIndex index(p);
  return estimate_scan_noise(fit_local_surfaces(p, index)).sigma_mm;
}

TEST(ScanNoise, ReadsTheNoiseOfPlanesAndSpheresWithinFivePercent) {
  const Points plane = clouds::graph_samples([](double x, double y) { return 0.3 * x - 0.2 * y; }, 0, 12, 0, 12, 0.2);
  const Points sphere = clouds::graph_samples([](double x, double y) { return std::sqrt(100 - x * x - y * y); }, -5, 5, -5,
                                              5, 0.2, [](double x, double y) { return std::hypot(x, y) <= 5; });
  for (double sigma : {0.005, 0.05}) {
    const double on_plane = noise_of(clouds::with_noise(plane, sigma, 21));
    const double on_sphere = noise_of(clouds::with_noise(sphere, sigma, 22));
    std::cout << "σ " << sigma << ": plane " << on_plane / sigma - 1 << ", sphere " << on_sphere / sigma - 1 << " relative error\n";
    EXPECT_NEAR(on_plane, sigma, 0.05 * sigma);
    EXPECT_NEAR(on_sphere, sigma, 0.05 * sigma);
  }
  EXPECT_LT(noise_of(plane), 1e-9);
  EXPECT_EQ(estimate_scan_noise({}).sigma_mm, 0);
}

// An exact scan whose views overlap where x > 9, registered 0.015 mm apart: two sheets there, the other
// 60 % of the points exact. The noise is the sheets' residue (≈ 0.0075 mm), not 0: at 0 every fit across
// the overlap would read as a crease (the case-3 block's Poisson resample without noise lost its whole
// top edge so).
TEST(ScanNoise, ReadsTheResidueOfViewsRegisteredAFewMicrometresApartOverAnExactScan) {
  const auto height = [](double x, double y) { return 0.3 * x - 0.2 * y; };
  const Points first = clouds::graph_samples(height, 0, 12, 0, 12, 0.2);
  const Points second = clouds::graph_samples([&](double x, double y) { return height(x, y) + 0.015; }, 9.1, 12, 0.1, 12, 0.2);
  Points both(first.rows() + second.rows(), 3);
  both << first, second;
  const double sigma = noise_of(both);
  EXPECT_GT(sigma, 0.004);
  EXPECT_LT(sigma, 0.01);
}

}  // namespace
}  // namespace cmm::geometry
