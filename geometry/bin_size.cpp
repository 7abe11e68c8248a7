// Ω from ε and the curvature of the most curved smooth region (not the most curved point: a crease or
// one noisy fit would drive B to 0), capped on flat scans; the region that set it is named.
#include "geometry/bin_size.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace cmm::geometry {

namespace {

constexpr double infinity = std::numeric_limits<double>::infinity();
constexpr Eigen::Index max_spacing_samples = 20'000;

std::string format(const char* pattern, auto... args) {
  char buffer[512];
  std::snprintf(buffer, sizeof buffer, pattern, args...);
  return buffer;
}

}  // namespace

double edge_length_for_tolerance(double tolerance_mm, double k1, double k2) {
  const double major = std::max(std::abs(k1), std::abs(k2)), sum = std::abs(k1) + std::abs(k2);
  if (!(major > 0)) return infinity;
  return std::sqrt(tolerance_mm * std::max(6 / major, 8 / sum));
}

double bin_for_edge_length(double edge_length_mm) { return edge_length_mm / kMaxEdgeBins; }

double median_spacing(const Points& points, const CloudIndex& index) {
  const Eigen::Index n = points.rows();
  if (n < 2) return 0;
  const Eigen::Index stride = std::max<Eigen::Index>(1, n / max_spacing_samples);
  const Eigen::Index samples = (n + stride - 1) / stride;
  std::vector<double> nearest(static_cast<std::size_t>(samples), infinity);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, samples, 512), [&](const tbb::blocked_range<Eigen::Index>& r) {
    std::vector<int> ids;
    std::vector<double> squared;
    for (Eigen::Index s = r.begin(); s < r.end(); ++s) {
      // A few neighbours, so that a duplicate of the point (distance 0) is stepped over.
      index.nearest(points.row(s * stride).transpose(), 4, ids, squared);
      for (double d : squared)
        if (d > 0) {
          nearest[static_cast<std::size_t>(s)] = std::sqrt(d);
          break;
        }
    }
  });
  std::erase_if(nearest, [](double d) { return !std::isfinite(d); });
  if (nearest.empty()) return 0;
  auto middle = nearest.begin() + static_cast<std::ptrdiff_t>(nearest.size() / 2);
  std::nth_element(nearest.begin(), middle, nearest.end());
  return *middle;
}

double sparse_density(const std::vector<LocalSurface>& fits, double quantile) {
  std::vector<double> density;
  for (const LocalSurface& f : fits)
    if (f.regular && f.radius_mm > 0) density.push_back(f.neighbours / (std::numbers::pi * f.radius_mm * f.radius_mm));
  if (density.empty()) return 0;
  const auto at = static_cast<std::ptrdiff_t>(std::clamp(quantile, 0.0, 1.0) * static_cast<double>(density.size() - 1));
  std::nth_element(density.begin(), density.begin() + at, density.end());
  return density[static_cast<std::size_t>(at)];
}

BinSize bin_size_for_tolerance(const Points& points, const std::vector<LocalSurface>& fits, const CloudIndex& index,
                               const BinSizeOptions& options) {
  const double eps = options.tolerance_mm;
  if (!(eps > 0) || !std::isfinite(eps))
    throw std::invalid_argument(format("bin size: the tolerance must be a positive number of mm, not %g", eps));
  if (fits.size() != static_cast<std::size_t>(points.rows()))
    throw std::invalid_argument(format("bin size: %zu fits for %lld points", fits.size(), static_cast<long long>(points.rows())));
  const std::size_t n = fits.size();

  // Each region's curvature: the mean of its regular fits' principal curvatures, signed against the
  // centre's normal. One fit's curvature is noisy (its standard error on a real scan can exceed the
  // curvature), and the most curved of 10⁵ noisy fits is the noise's tail, not the surface: the mean
  // over `region_points` overlapping fits (about region_points / k independent ones) is what must be
  // significant. A region more than a quarter irregular (a crease, a corner) says nothing.
  const auto region_size = static_cast<std::size_t>(std::max(options.region_points, 1));
  const std::size_t centre_stride = std::max<std::size_t>(1, region_size / 8);
  std::vector<double> region(n, infinity), region_k1(n, 0), region_k2(n, 0), hidden(n, infinity);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<int> ids;
    std::vector<double> squared;
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      const LocalSurface& centre = fits[i];
      // Regions of 64 overlap by most of their points: every 8th point as a centre sees them all, at
      // an eighth of the cost.
      if (!centre.regular || i % centre_stride != 0) continue;
      index.nearest(points.row(static_cast<Eigen::Index>(i)).transpose(), region_size, ids, squared);
      if (ids.size() < std::min(region_size, n)) continue;
      double high = 0, low = 0, sigma = 0;
      std::size_t regular = 0;
      for (int j : ids) {
        const LocalSurface& f = fits[static_cast<std::size_t>(j)];
        if (!f.regular) continue;
        const double sign = f.normal.dot(centre.normal) >= 0 ? 1 : -1;
        high += std::max(sign * f.k1, sign * f.k2), low += std::min(sign * f.k1, sign * f.k2);
        sigma += f.curvature_sigma;
        ++regular;
      }
      if (4 * regular < 3 * ids.size()) continue;
      high /= static_cast<double>(regular), low /= static_cast<double>(regular), sigma /= static_cast<double>(regular);
      const double independent = std::max(1.0, static_cast<double>(regular) / std::max(1, centre.neighbours));
      const double k1 = std::abs(high) >= std::abs(low) ? high : low, k2 = std::abs(high) >= std::abs(low) ? low : high;
      hidden[i] = options.significance * sigma / std::sqrt(independent);
      if (!(std::abs(k1) > 0) || std::abs(k1) < options.significance * sigma / std::sqrt(independent)) continue;
      region[i] = edge_length_for_tolerance(eps, k1, k2);
      region_k1[i] = k1, region_k2[i] = k2;
    }
  });

  BinSize result;
  result.regular_points = static_cast<std::size_t>(std::count_if(fits.begin(), fits.end(), [](const LocalSurface& f) { return f.regular; }));
  std::size_t best = n;
  for (std::size_t i = 0; i < n; ++i)
    if (std::isfinite(region[i]) && (best == n || region[i] < region[best])) best = i;

  result.median_spacing_mm = median_spacing(points, index);
  double diagonal = 0;
  if (points.rows() > 0) diagonal = (points.colwise().maxCoeff() - points.colwise().minCoeff()).norm();
  result.sparse_density_per_mm2 = sparse_density(fits, options.sparse_quantile);
  result.sampling_floor_mm =
      result.sparse_density_per_mm2 > 0 ? std::sqrt(options.samples_per_bin / result.sparse_density_per_mm2) : 0;
  const std::string floor_text = format("the sampling floor %.4f mm (%g raw points per bin where the scan holds %.1f per mm²)",
                                        result.sampling_floor_mm, options.samples_per_bin, result.sparse_density_per_mm2);
  const double spacing_cap = options.spacing_cap * result.median_spacing_mm, size_cap = options.size_cap * diagonal;
  const double cap = std::max({spacing_cap, size_cap, result.sampling_floor_mm});
  const std::string cap_text = cap == result.sampling_floor_mm ? floor_text
                               : cap == spacing_cap ? format("%g × the median raw spacing %.4f mm", options.spacing_cap, result.median_spacing_mm)
                                                    : format("%g × the cloud's diagonal %.1f mm", options.size_cap, diagonal);

  // What the noise could hide: a curvature below the median region's significance threshold is not
  // told from noise anywhere, so an "insignificant" region may still curve that much. B never exceeds
  // what that curvature allows (on a noise-free scan it is 0 and this bin infinite).
  std::vector<double> thresholds;
  for (double h : hidden)
    if (std::isfinite(h)) thresholds.push_back(h);
  double hidden_k = 0;
  if (!thresholds.empty()) {
    auto middle = thresholds.begin() + static_cast<std::ptrdiff_t>(thresholds.size() / 2);
    std::nth_element(thresholds.begin(), middle, thresholds.end());
    hidden_k = *middle;
  }
  const double hidden_bin = bin_for_edge_length(edge_length_for_tolerance(eps, hidden_k, hidden_k));

  if (best == n || hidden_bin < bin_for_edge_length(region[best])) {
    if (hidden_bin < cap) {
      // The hidden curvature is a bound, not a measurement: a bin below the sampling floor buys no
      // accuracy, only empty bins (pinholes). A measured curvature still wins: B rises toward the floor
      // but never beyond what the most curved region allows at ε.
      const double measured = best == n ? infinity : bin_for_edge_length(region[best]);
      const double bin = std::max(hidden_bin, std::min(result.sampling_floor_mm, measured));
      result.bin_mm = bin;
      result.edge_length_mm = kMaxEdgeBins * bin;
      result.noise_limited = true;
      result.sampling_limited = bin > hidden_bin;
      result.k1 = hidden_k;
      result.second_derivative_sum = 2 * hidden_k;
      result.source = format("tolerance %.3f mm against the scan's noise: a curvature below %.4f /mm is not told from "
                             "noise in a region of %zu points, and B allows it everywhere",
                             eps, hidden_k, region_size);
      if (result.sampling_limited)
        result.source += format("; raised to %s", result.sampling_floor_mm <= measured ? floor_text.c_str() : "what the most curved region allows");
      return result;
    }
    if (best == n) {
      result.capped = true;
      result.bin_mm = cap;
      result.edge_length_mm = kMaxEdgeBins * cap;
      result.source = format("no significant curvature among %zu regular points: bin capped at %s", result.regular_points,
                             cap_text.c_str());
      return result;
    }
  }
  const LocalSurface& at = fits[best];
  result.point = best;
  result.where = at.origin;
  result.k1 = region_k1[best];
  result.second_derivative_sum = std::abs(region_k1[best]) + std::abs(region_k2[best]);
  result.edge_length_mm = region[best];
  result.bin_mm = bin_for_edge_length(region[best]);
  const std::string region_text =
      format("the most curved region near (%.3f, %.3f, %.3f) mm, curvature %.4f /mm over %zu points", at.origin.x(),
             at.origin.y(), at.origin.z(), std::abs(result.k1), region_size);
  if (result.bin_mm > cap) {
    result.capped = true;
    result.source = format("tolerance %.3f mm would allow %.3f mm at %s: bin capped at %s", eps, result.bin_mm,
                           region_text.c_str(), cap_text.c_str());
    result.bin_mm = cap;
    result.edge_length_mm = kMaxEdgeBins * cap;
    return result;
  }
  result.source = format("tolerance %.3f mm at %s", eps, region_text.c_str());
  return result;
}

DensityCheck check_density(const BinSize& bin, double tolerance_mm) {
  DensityCheck check;
  if (bin.capped || !(bin.bin_mm > 0) || !(bin.median_spacing_mm > bin.bin_mm)) return check;
  check.too_sparse = true;
  check.tolerance_needed_mm = tolerance_mm * std::pow(bin.median_spacing_mm / bin.bin_mm, 2);
  return check;
}

}  // namespace cmm::geometry
