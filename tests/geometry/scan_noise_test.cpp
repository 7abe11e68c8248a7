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

}  // namespace
}  // namespace cmm::geometry
