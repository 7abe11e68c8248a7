// The scan's noise σ along the surface normal, from the local quadric fits' residuals: the planner's
// δ (how far a probe point may sit off the reference) can then come from the scan itself.
#pragma once

#include <cstddef>
#include <vector>

#include "geometry/local_surface.hpp"

namespace cmm::geometry {

struct ScanNoise {
  double sigma_mm = 0;         // 0 when no fit could speak for it
  std::size_t fits_used = 0;   // regular fits with more points than the quadric's 6 terms
};

// Median over the regular fits of their residual RMS, corrected for the 6 fitted terms (a fit of n
// points leaves n − 6 degrees of freedom) and for the median of a χ² not being its mean. Robust to
// creases and outliers as long as most fits are on smooth surface. Where over half the fits are exact
// and at least a quarter are not (exact views registered a few µm apart), the median of those that
// are not. Deterministic.
ScanNoise estimate_scan_noise(const std::vector<LocalSurface>& fits);

// One fit's residual RMS as an estimate of σ (the degrees-of-freedom correction only); 0 when the fit
// has no spare degree of freedom.
double residual_sigma(const LocalSurface& fit);

}  // namespace cmm::geometry
