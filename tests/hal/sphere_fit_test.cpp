// Sphere fit against known spheres: exact points, a cap only, noise, and degenerate input.
#include "hal/sphere_fit.hpp"

#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

namespace cmm::hal {
namespace {

// Points on a cap of the sphere (centre c, radius r): the pole and a ring at `latitude` — what
// qualification touches.
std::vector<Vec3> cap(const Vec3& c, double r, int ring, double latitude) {
  std::vector<Vec3> pts{c + r * Vec3::UnitZ()};
  for (int i = 0; i < ring; ++i) {
    double a = 2 * std::numbers::pi * i / ring;
    pts.push_back(c + r * Vec3(std::cos(latitude) * std::cos(a), std::cos(latitude) * std::sin(a), std::sin(latitude)));
  }
  return pts;
}

TEST(SphereFit, ExactOnACap) {
  const Vec3 c(600, 800, 25);
  SphereFit fit = fit_sphere(cap(c, 13.5, 8, 0.5));
  EXPECT_LT((fit.centre - c).norm(), 1e-9);
  EXPECT_NEAR(fit.radius, 13.5, 1e-9);
  EXPECT_LT(fit.residual_rms, 1e-9);
}

TEST(SphereFit, NoiseStaysNearItsSize) {
  const Vec3 c(1, 2, 3);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0, 0.001);
  double worst_radius = 0;
  for (int trial = 0; trial < 100; ++trial) {
    auto pts = cap(c, 13.5, 8, 0.5);
    for (auto& p : pts) p += noise(rng) * (p - c).normalized();
    SphereFit fit = fit_sphere(pts);
    worst_radius = std::max(worst_radius, std::abs(fit.radius - 13.5));
    EXPECT_LT((fit.centre - c).norm(), 0.01);
  }
  // Nine radial errors of 1 µm σ over a 30° cap: the radius is known to a few µm.
  EXPECT_LT(worst_radius, 0.006);
}

TEST(SphereFit, RefusesTooFewOrFlatPoints) {
  EXPECT_THROW(fit_sphere({Vec3::Zero(), Vec3::UnitX(), Vec3::UnitY()}), std::invalid_argument);
  EXPECT_THROW(fit_sphere({Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(0, -1, 0), Vec3(0.6, 0.8, 0)}),
               std::invalid_argument);
  EXPECT_THROW(fit_sphere({Vec3(NAN, 0, 0), Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(0, 0, 1)}), std::invalid_argument);
}

}  // namespace
}  // namespace cmm::hal
