// Point clouds sampled from analytic surfaces with known curvature, for the scan front end's fit,
// bin-size, thinning and outlier tests: grids over Monge patches, a bicone band, noise.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry::clouds {

struct MongeDerivatives {
  double fx = 0, fy = 0, fxx = 0, fxy = 0, fyy = 0;
};

struct Curvatures {
  double k1 = 0, k2 = 0;  // |k1| ≥ |k2|, signed for the normal (−fx, −fy, 1)
};

// Principal curvatures of z = f(x, y) from its first and second derivatives: K = (f_xx f_yy − f_xy²)/W²,
// H = ((1 + f_y²) f_xx − 2 f_x f_y f_xy + (1 + f_x²) f_yy) / (2 W^{3/2}), W = 1 + f_x² + f_y², k = H ± √(H² − K).
inline Curvatures monge_curvatures(const MongeDerivatives& d) {
  const double w = 1 + d.fx * d.fx + d.fy * d.fy;
  const double k = (d.fxx * d.fyy - d.fxy * d.fxy) / (w * w);
  const double h = ((1 + d.fy * d.fy) * d.fxx - 2 * d.fx * d.fy * d.fxy + (1 + d.fx * d.fx) * d.fyy) / (2 * std::pow(w, 1.5));
  const double root = std::sqrt(std::max(0.0, h * h - k));
  Curvatures c{h + root, h - root};
  if (std::abs(c.k2) > std::abs(c.k1)) std::swap(c.k1, c.k2);
  return c;
}

inline Points from_rows(const std::vector<Vec3>& rows) {
  Points p(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t i = 0; i < rows.size(); ++i) p.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
  return p;
}

// z = f(x, y) on the grid x0 + i·h, y0 + j·h within [x0, x1] × [y0, y1] where `keep` says so.
inline Points graph_samples(const std::function<double(double, double)>& f, double x0, double x1, double y0, double y1,
                            double h, const std::function<bool(double, double)>& keep = {}) {
  std::vector<Vec3> rows;
  const int nx = static_cast<int>(std::floor((x1 - x0) / h + 1e-9)), ny = static_cast<int>(std::floor((y1 - y0) / h + 1e-9));
  for (int i = 0; i <= nx; ++i)
    for (int j = 0; j <= ny; ++j) {
      const double x = x0 + i * h, y = y0 + j * h;
      if (!keep || keep(x, y)) rows.emplace_back(x, y, f(x, y));
    }
  return from_rows(rows);
}

// Two cones of rim radius R and height H joined at their rims (the crease z = 0, ρ = R): a band
// |z| ≤ half_band of the sector 0 ≤ θ ≤ sector_rad, sampled at about h along the slant and around.
inline Points bicone_band(double radius, double height, double half_band, double sector_rad, double h) {
  std::vector<Vec3> rows;
  const double slant = std::hypot(radius, height) / height;  // slant length per unit of z
  const int steps = static_cast<int>(std::round(half_band * slant / h));
  for (int s = -steps; s <= steps; ++s) {
    const double z = s * h / slant;
    const double rho = radius * (1 - std::abs(z) / height);
    const int around = std::max(1, static_cast<int>(std::round(rho * sector_rad / h)));
    for (int t = 0; t <= around; ++t) {
      const double theta = sector_rad * t / around;
      rows.emplace_back(rho * std::cos(theta), rho * std::sin(theta), z);
    }
  }
  return from_rows(rows);
}

// Gaussian noise of σ on every coordinate (isotropic: σ along any normal too); same seed, same cloud.
inline Points with_noise(Points p, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, sigma);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int k = 0; k < 3; ++k) p(i, k) += g(rng);
  return p;
}

}  // namespace cmm::geometry::clouds
