// Where a scan's points lie on the true part before noise: a scanner's raster (grid) and a merging
// tool's Poisson-disk resampling of the views' union. The random sampler stays in raw_scan.cpp, where
// its draws interleave with the noise's in the order its scans have always had.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "geometry/mesh.hpp"
#include "sim/scan_views.hpp"
#include "sim/view_coverage.hpp"
#include "sim/visibility.hpp"

namespace cmm::sim {

// A true surface point one view saw.
struct SurfaceSample {
  geometry::Vec3 point;
  int face = -1;  // scene face it lies on
  int view = -1;  // index into the views
};

// What the samplers read; all lists have one entry per view.
struct SamplerInput {
  const ScanVisibility& visibility;
  const std::vector<ScanView>& views;
  const std::vector<CoverageBand>& coverage;
  const std::vector<double>& density;  // factor on 1 / spacing²
  double spacing_mm;
  std::uint64_t seed;
};

// Poisson-disk: no two kept points nearer than kPoissonRadius · spacing, chosen greedily in random order
// from kPoissonCandidates / spacing² area-uniform candidates. Random sequential adsorption with that many
// tries per disk stops short of jamming (which would give 1.42 / spacing² at this radius) at 1.00 points
// per spacing² on a plane face, measured (tests/sim/scan_sampling_test.cpp; radius 0.68 with 4
// candidates gives 0.99, 0.70 with 4 gives 0.95).
inline constexpr double kPoissonRadius = 0.7;
inline constexpr double kPoissonCandidates = 5;

// A point uniform over the triangle's area (the square-root map of two uniform numbers).
geometry::Vec3 sample_triangle(std::mt19937_64& engine, const geometry::Vec3& a, const geometry::Vec3& b,
                               const geometry::Vec3& c);

// Each view casts parallel beams from a square lattice of pitch spacing / √density across its image
// (image_axes; the lattice shifted by a random fraction of a pitch per view, SeedStream::grid_offsets);
// a beam lands on the first face it meets: on a face the view faces, at a lattice point inside the
// face's projection (shared edges go to one face only), kept if nothing hides it and it lies in the
// view's band. In view, face, lattice order.
std::vector<SurfaceSample> grid_samples(const SamplerInput& input);

// Candidates area-uniform over every face some view faces, each credited to one view that sees it
// (within its band), chosen at random with odds in proportion to the views' densities; then greedy
// Poisson-disk thinning in a random order (SeedStream::poisson). In view order, then face order.
// Throws std::invalid_argument if the part is too large for the spacing (over 2²⁰ radii across).
std::vector<SurfaceSample> poisson_samples(const SamplerInput& input);

}  // namespace cmm::sim
