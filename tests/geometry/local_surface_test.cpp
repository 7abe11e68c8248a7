// Local quadric fits against surfaces of known curvature (hemisphere, cone, the thesis's §4.4.1
// surface, a bicone's crease), with and without noise, and on inputs that have no surface at all.
#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <iostream>
#include <numbers>

#include "geometry/cloud_index.hpp"
#include "geometry/local_surface.hpp"
#include "analytic_clouds.hpp"

namespace cmm::geometry {
namespace {

using clouds::Curvatures;
using clouds::MongeDerivatives;

struct Errors {
  double k1_relative = 0;  // largest |k1 − true| / |true k1|
  double k2_absolute = 0;  // largest |k2 − true k2|
  double k2_relative = 0;  // largest |k2 − true| / |true k1|
  int checked = 0, irregular = 0;
};

// Compares each fit whose origin passes `use` with the truth at the origin's (x, y), the curvature's
// sign taken for the normal with +z.
Errors compare(const Points& points, const std::vector<LocalSurface>& fits,
               const std::function<MongeDerivatives(double, double)>& truth,
               const std::function<bool(double, double)>& use) {
  Errors e;
  for (std::size_t i = 0; i < fits.size(); ++i) {
    const LocalSurface& s = fits[i];
    const double x = s.origin.x(), y = s.origin.y();
    if (!use(points(static_cast<Eigen::Index>(i), 0), points(static_cast<Eigen::Index>(i), 1)) || !use(x, y)) continue;
    ++e.checked;
    if (!s.regular) ++e.irregular;
    const Curvatures t = clouds::monge_curvatures(truth(x, y));
    const double sign = s.normal.z() >= 0 ? 1 : -1;
    // Paired by value, not by |k|: at a symmetric saddle (the thesis surface's centre) which of the
    // two is "k1" is a coin toss.
    const double high_error = std::abs(std::max(sign * s.k1, sign * s.k2) - std::max(t.k1, t.k2));
    const double low_error = std::abs(std::min(sign * s.k1, sign * s.k2) - std::min(t.k1, t.k2));
    const bool high_is_major = std::max(t.k1, t.k2) == t.k1;
    const double major_error = high_is_major ? high_error : low_error, minor_error = high_is_major ? low_error : high_error;
    e.k1_relative = std::max(e.k1_relative, major_error / std::abs(t.k1));
    e.k2_absolute = std::max(e.k2_absolute, minor_error);
    e.k2_relative = std::max(e.k2_relative, minor_error / std::abs(t.k1));
  }
  return e;
}

std::vector<LocalSurface> fits_of(const Points& points, int k = 25) {
  const CloudIndex index(points);
  return fit_local_surfaces(points, index, {k, {}});
}

constexpr double sphere_r = 10;
double sphere(double x, double y) { return std::sqrt(sphere_r * sphere_r - x * x - y * y); }
MongeDerivatives sphere_derivatives(double x, double y) {
  const double z = sphere(x, y), z3 = z * z * z;
  return {-x / z, -y / z, -(sphere_r * sphere_r - y * y) / z3, -x * y / z3, -(sphere_r * sphere_r - x * x) / z3};
}

// Cone z = h − m·ρ: the circumferential curvature is m / (ρ √(1 + m²)) = cos α / ρ (α the half angle
// between axis and surface), the one along the generator 0.
constexpr double cone_m = 1.0;
double cone(double x, double y) { return 10 - cone_m * std::hypot(x, y); }
MongeDerivatives cone_derivatives(double x, double y) {
  const double r = std::hypot(x, y), r3 = r * r * r;
  return {-cone_m * x / r, -cone_m * y / r, -cone_m * y * y / r3, cone_m * x * y / r3, -cone_m * x * x / r3};
}

// Thesis §4.4.1: z = a·√(x² − y² + r²), a = h / r², r = 2, h = 3.
constexpr double thesis_r = 2, thesis_a = 3.0 / (thesis_r * thesis_r);
double thesis_radicand(double x, double y) { return x * x - y * y + thesis_r * thesis_r; }
double thesis(double x, double y) { return thesis_a * std::sqrt(thesis_radicand(x, y)); }
MongeDerivatives thesis_derivatives(double x, double y) {
  const double q = std::sqrt(thesis_radicand(x, y)), q3 = q * q * q;
  return {thesis_a * x / q, -thesis_a * y / q, thesis_a * (thesis_r * thesis_r - y * y) / q3, thesis_a * x * y / q3,
          -thesis_a * (thesis_r * thesis_r + x * x) / q3};
}

TEST(LocalSurface, HemisphereCurvatureWithinOnePercent) {
  // r = 10 mm at 0.2 mm: 25 neighbours span ±0.6 mm.
  const Points p = clouds::graph_samples(sphere, -8, 8, -8, 8, 0.2, [](double x, double y) { return std::hypot(x, y) <= 8; });
  const auto fits = fits_of(p);
  const Errors e = compare(p, fits, sphere_derivatives, [](double x, double y) { return std::hypot(x, y) <= 7; });
  std::cout << "hemisphere: k1 " << e.k1_relative << ", k2 " << e.k2_relative << " of k1, over " << e.checked << "\n";
  EXPECT_GT(e.checked, 3000);
  EXPECT_EQ(e.irregular, 0);
  EXPECT_LT(e.k1_relative, 0.01);
  EXPECT_LT(e.k2_relative, 0.01);
}

TEST(LocalSurface, ConeCurvatureWithinFivePercentAndNoneAlongTheGenerator) {
  const Points p = clouds::graph_samples(cone, 2, 8, -3, 3, 0.1);
  const auto fits = fits_of(p);
  const Errors e = compare(p, fits, cone_derivatives, [](double x, double y) {
    return std::hypot(x, y) >= 3 && x <= 7.5 && std::abs(y) <= 2.5;
  });
  std::cout << "cone: k1 " << e.k1_relative << ", |k2| " << e.k2_absolute << " /mm over " << e.checked << "\n";
  EXPECT_GT(e.checked, 1500);
  EXPECT_EQ(e.irregular, 0);
  EXPECT_LT(e.k1_relative, 0.05);
  EXPECT_LT(e.k2_absolute, 0.005);  // k1 here is 0.09–0.24 /mm
}

TEST(LocalSurface, ThesisSurfaceCurvatureWithinFivePercent) {
  const Points p = clouds::graph_samples(thesis, -thesis_r, thesis_r, -thesis_r, thesis_r, 0.04);
  const auto fits = fits_of(p);
  const Errors e = compare(p, fits, thesis_derivatives, [](double x, double y) {
    return thesis_radicand(x, y) >= 1 && std::max(std::abs(x), std::abs(y)) <= thesis_r - 0.2;
  });
  std::cout << "thesis surface: k1 " << e.k1_relative << ", k2 " << e.k2_relative << " of k1 over " << e.checked << "\n";
  EXPECT_GT(e.checked, 5000);
  EXPECT_EQ(e.irregular, 0);
  EXPECT_LT(e.k1_relative, 0.05);
  EXPECT_LT(e.k2_relative, 0.05);
}

TEST(LocalSurface, BiconeCreaseIsIrregularAndTheConesAreNot) {
  constexpr double radius = 10, height = 15, h = 0.1;
  const Points p = clouds::bicone_band(radius, height, 3, 1.0, h);
  const auto fits = fits_of(p);
  const double sin_alpha = radius / std::hypot(radius, height);  // cone_m = H / R; k1 = cos(half angle) / ρ
  int crease = 0, crease_regular = 0, side = 0, side_irregular = 0;
  double worst = 0;
  for (std::size_t i = 0; i < fits.size(); ++i) {
    const Vec3 q = p.row(static_cast<Eigen::Index>(i)).transpose();
    const double z = std::abs(q.z()), theta = std::atan2(q.y(), q.x());
    if (z < 0.5 * h) {
      ++crease;
      crease_regular += fits[i].regular;
    } else if (z > 1.0 && theta > 0.1 && theta < 0.9) {
      ++side;
      side_irregular += !fits[i].regular;
      const Vec3 o = fits[i].origin;
      const double truth = (height / std::hypot(radius, height)) / std::hypot(o.x(), o.y());
      worst = std::max(worst, std::abs(std::abs(fits[i].k1) - truth) / truth);
    }
  }
  (void)sin_alpha;
  std::cout << "bicone: crease " << crease << " points, " << crease_regular << " regular; sides " << side << ", "
            << side_irregular << " irregular, k1 " << worst << "\n";
  EXPECT_GT(crease, 50);
  EXPECT_EQ(crease_regular, 0);
  EXPECT_EQ(side_irregular, 0);
  EXPECT_LT(worst, 0.05);
}

TEST(LocalSurface, NoisyHemisphereCurvatureErrorIsWhatItsSigmaSays) {
  constexpr double sigma = 0.01;
  const Points p = clouds::with_noise(
      clouds::graph_samples(sphere, -8, 8, -8, 8, 0.2, [](double x, double y) { return std::hypot(x, y) <= 8; }), sigma, 11);
  const auto fits = fits_of(p);
  int checked = 0, within = 0, irregular = 0;
  double mean_k1 = 0, mean_sigma = 0;
  for (std::size_t i = 0; i < fits.size(); ++i) {
    if (std::hypot(fits[i].origin.x(), fits[i].origin.y()) > 7) continue;
    ++checked;
    irregular += !fits[i].regular;
    const double sign = fits[i].normal.z() >= 0 ? 1 : -1;
    const double k1 = sign * fits[i].k1, truth = -1 / sphere_r;
    mean_k1 += k1;
    mean_sigma += fits[i].curvature_sigma;
    within += std::abs(k1 - truth) <= 2.5 * fits[i].curvature_sigma;
  }
  mean_k1 /= checked, mean_sigma /= checked;
  std::cout << "noisy hemisphere σ " << sigma << ": mean k1 " << mean_k1 << ", mean curvature σ " << mean_sigma << ", "
            << 100.0 * within / checked << " % within 2.5 σ, " << irregular << " irregular\n";
  // |k1| is the larger of two noisy estimates of 0.1: biased up by about the curvature σ.
  EXPECT_NEAR(-mean_k1, 0.1, mean_sigma);
  EXPECT_GT(static_cast<double>(within) / checked, 0.9);
  EXPECT_LT(irregular, checked / 100);
}

TEST(LocalSurface, DegenerateNeighbourhoodsAreFiniteAndIrregular) {
  auto finite = [](const LocalSurface& s) {
    return s.origin.allFinite() && s.normal.allFinite() && s.u.allFinite() && s.v.allFinite() && std::isfinite(s.a) &&
           std::isfinite(s.b) && std::isfinite(s.c) && std::isfinite(s.k1) && std::isfinite(s.k2) &&
           std::isfinite(s.curvature_sigma) && std::isfinite(s.residual_rms_mm) && std::isfinite(s.plane_spread) &&
           std::isfinite(s.radius_mm);
  };
  std::vector<int> ids(25);
  for (int i = 0; i < 25; ++i) ids[i] = i;
  Points same(25, 3);
  same.rowwise() = Eigen::RowVector3d(1, 2, 3);
  Points line(25, 3);
  for (int i = 0; i < 25; ++i) line.row(i) << i * 0.1, 2 * i * 0.1, 1;
  Points two(25, 3);  // two points, each repeated
  for (int i = 0; i < 25; ++i) two.row(i) << i % 2, 0, 0;
  Points circle(25, 3);  // coplanar but a conic: the quadric is not determined
  for (int i = 0; i < 25; ++i) circle.row(i) << std::cos(i * 0.25), std::sin(i * 0.25), 0;
  for (const Points* p : {&same, &line, &two, &circle}) {
    const LocalSurface s = fit_local_surface(*p, ids);
    EXPECT_TRUE(finite(s));
    EXPECT_FALSE(s.regular);
  }
  // Fewer points than the quadric's six terms: finite, irregular.
  const LocalSurface few = fit_local_surface(line, {0, 1, 2});
  EXPECT_TRUE(finite(few));
  EXPECT_FALSE(few.regular);
  // Whole clouds of them through fit_local_surfaces, and a cloud far from the origin.
  for (const Points* p : {&same, &line, &two}) {
    const CloudIndex index(*p);
    for (const LocalSurface& s : fit_local_surfaces(*p, index)) {
      EXPECT_TRUE(finite(s));
      EXPECT_FALSE(s.regular);
    }
  }
}

TEST(LocalSurface, FarFromTheOriginKeepsItsDigits) {
  Points p = clouds::graph_samples(sphere, -2, 2, -2, 2, 0.2);
  p.rowwise() += Eigen::RowVector3d(1e6, -1e6, 5e5);
  const auto fits = fits_of(p);
  const LocalSurface& s = fits[fits.size() / 2];
  EXPECT_TRUE(s.regular);
  EXPECT_NEAR(std::abs(s.k1), 0.1, 0.002);
}

TEST(LocalSurface, SameResultOnOneAndTwoThreads) {
  const Points p = clouds::with_noise(clouds::graph_samples(thesis, -thesis_r, thesis_r, -thesis_r, thesis_r, 0.08), 0.005, 3);
  std::vector<LocalSurface> one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = fits_of(p);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = fits_of(p);
  }
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t i = 0; i < one.size(); ++i) {
    ASSERT_EQ(one[i].k1, two[i].k1) << i;
    ASSERT_EQ(one[i].residual_rms_mm, two[i].residual_rms_mm) << i;
    ASSERT_EQ(one[i].regular, two[i].regular) << i;
    ASSERT_TRUE(one[i].origin == two[i].origin) << i;
  }
}

TEST(LocalSurface, CancelStopsTheFits) {
  const Points p = clouds::graph_samples(sphere, -2, 2, -2, 2, 0.1);
  const CloudIndex index(p);
  LocalSurfaceOptions options;
  options.cancel.requested = [] { return true; };
  EXPECT_THROW(fit_local_surfaces(p, index, options), Cancelled);
}

}  // namespace
}  // namespace cmm::geometry
