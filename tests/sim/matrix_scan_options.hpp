// The raw-scan options of the scan matrix's random samplings (bench/scan_matrix.sh): five views 0.02 mm
// apart in registration, 0.5 % strays, isotropic noise, at 0.25 mm; "views" are partial (80 % each) and of
// density 0.4–2×. For tests that hold one of the matrix's cases.
#pragma once

#include <cstdint>

#include "sim/raw_scan.hpp"
#include "sim/scan_views.hpp"

namespace cmm::testing {

inline sim::RawScanOptions matrix_random_scan(double sigma, std::uint64_t seed, bool partial_views) {
  sim::RawScanOptions options;
  options.spacing_mm = 0.25;
  options.noise_sigma_mm = sigma;
  options.stray_fraction = 0.005;
  options.seed = seed;
  options.views = sim::views_with_offset(5, 0.02, seed);
  options.sampling = sim::ScanSampling::random;
  options.noise_model = sim::ScanNoise::isotropic;
  if (partial_views) {
    options.view_coverage = 0.8;
    options.view_density = {1.0, 0.4, 2.0, 0.7, 1.5};
  }
  return options;
}

}  // namespace cmm::testing
