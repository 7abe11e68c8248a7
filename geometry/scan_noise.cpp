// The median of the fits' dof-corrected residuals: a scan's noise from its smooth parts only.
#include "geometry/scan_noise.hpp"

#include <algorithm>
#include <cmath>

namespace cmm::geometry {

namespace {
constexpr int quadric_terms = 6;
// A fit's σ estimate below this fraction of its radius is rounding: the points lie on an exact surface.
constexpr double kExactFraction = 1e-6;
}

double residual_sigma(const LocalSurface& fit) {
  const int dof = fit.neighbours - quadric_terms;
  if (dof <= 0 || !std::isfinite(fit.residual_rms_mm)) return 0;
  // RSS / dof estimates σ²; the residual RMS is √(RSS / n).
  return fit.residual_rms_mm * std::sqrt(static_cast<double>(fit.neighbours) / dof);
}

ScanNoise estimate_scan_noise(const std::vector<LocalSurface>& fits) {
  ScanNoise result;
  std::vector<double> sigmas, inexact;
  sigmas.reserve(fits.size());
  for (const LocalSurface& fit : fits) {
    if (!fit.regular) continue;
    const int dof = fit.neighbours - quadric_terms;
    if (dof <= 0) continue;
    // s² = RSS / dof is σ²·χ²_dof / dof, whose median is about (1 − 2/(9·dof))³ (Wilson–Hilferty):
    // 0.965 at 25 neighbours, so an uncorrected median would read σ 2 % low.
    const double median_ratio = std::pow(1 - 2.0 / (9.0 * dof), 3);
    sigmas.push_back(residual_sigma(fit) / std::sqrt(median_ratio));
    if (sigmas.back() > kExactFraction * fit.radius_mm) inexact.push_back(sigmas.back());
  }
  result.fits_used = sigmas.size();
  if (sigmas.empty()) return result;
  // Mostly exact, with a sizeable rest: views registered a few µm apart over an otherwise exact scan. The
  // rest is that residue (two sheets 0.01–0.02 mm apart), the noise every fit across an overlap shows;
  // creases, a few percent of the fits, never make up a quarter.
  std::vector<double>& of = 2 * inexact.size() < sigmas.size() && 4 * inexact.size() >= sigmas.size() ? inexact : sigmas;
  auto middle = of.begin() + static_cast<std::ptrdiff_t>(of.size() / 2);
  std::nth_element(of.begin(), middle, of.end());
  result.sigma_mm = *middle;
  return result;
}

}  // namespace cmm::geometry
