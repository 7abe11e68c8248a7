// Partial views: each view keeps only a share of the surface it sees, as one contiguous band across its
// image, so that views overlap in bands as a scanner's partial views of a part do.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "geometry/mesh.hpp"
#include "sim/scan_views.hpp"
#include "sim/visibility.hpp"

namespace cmm::sim {

// The half-space of the scene a view keeps: the points p with direction · p ≤ limit_mm.
struct CoverageBand {
  geometry::Vec3 direction = geometry::Vec3::Zero();  // unit, across the view's image; zero: the whole view
  double limit_mm = std::numeric_limits<double>::infinity();
  bool keeps(const geometry::Vec3& p) const { return direction.dot(p) <= limit_mm; }
};

// Samples of a view's seen surface the band's limit is estimated from: its share is then within about
// 0.5 % (one standard error 0.3 %) of the asked coverage.
inline constexpr int kCoverageEstimateSamples = 20000;

// How a view's share is counted: as its sampling spreads points. Random and Poisson samples are uniform
// over the surface; a raster's are uniform over the view's image, so a face there counts by its area
// times the cosine of its incidence.
enum class CoverageMeasure { surface_area, image_area };

// One band per view. coverage 1 gives whole views and draws nothing. Otherwise each view's direction is
// drawn uniformly across its image (normal to the view direction: a scanner's field cut short on one
// side), and its limit is the coverage quantile of direction · p over what the view sees, by `measure`,
// estimated from kCoverageEstimateSamples samples: each view keeps about `coverage` of its points.
// Seeded by SeedStream::coverage_bands. Throws std::invalid_argument unless 0 < coverage ≤ 1.
std::vector<CoverageBand> coverage_bands(const ScanVisibility& visibility, const std::vector<ScanView>& views,
                                         double coverage, CoverageMeasure measure, std::uint64_t seed);

}  // namespace cmm::sim
