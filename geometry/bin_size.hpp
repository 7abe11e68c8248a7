// The voxel bin size B from the tolerance ε (thesis §3.2–3.4): the longest triangle edge Ω the
// surface's curvature allows at ε, B = Ω/√3, set by the most curved smooth region of the scan.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "geometry/cloud_index.hpp"
#include "geometry/local_surface.hpp"
#include "geometry/mesh.hpp"

namespace cmm::geometry {

// The longest edge Ω of a triangle whose linear interpolation of a quadric with principal curvatures
// k1, k2 stays within ε of it. Two bounds hold for any triangle with edges ≤ Ω, and the tighter wins:
//  • |e| ≤ λ_max(|H|)·R²/2 with R ≤ Ω/√3 the triangle's smallest enclosing circle, i.e. |k1|·Ω²/6
//    (exact for an equilateral triangle on a sphere);
//  • the thesis's eq. 3.2, |e| ≤ Ω²/8·(M1 + 2·M2 + M3) with M the second derivatives (2a, b, 2c —
//    not a, b, c as eq. 3.9 has them), taken in the principal frame where M2 = 0: (|k1| + |k2|)·Ω²/8
//    (exact for an edge across a cylinder).
// So Ω² = ε·max(6/|k1|, 8/(|k1| + |k2|)); infinite on a plane.
double edge_length_for_tolerance(double tolerance_mm, double k1, double k2);

// The longest mesh edge a bin size B needs, in bins: √6. Eq. 3.12's √3·B holds for points at the
// bins' centres, but the kept point is only the one nearest its centre, anywhere in the bin; two points
// in bins that share a face lie up to √(2² + 1 + 1)·B apart, and the triangulation must join those, or
// a surface that crosses the grid obliquely gets holes. So the triangulation's edges reach √6·B.
inline constexpr double kMaxEdgeBins = 2.449489742783178;

// B = Ω/√6: every edge the triangulation may make (≤ √6·B) is short enough for ε. The thesis's
// B = Ω/√3 (eq. 3.13) lets edges of up to twice the Ω² through: measured, a cone meshed at ε = 0.02 mm
// came out 0.037 mm off.
double bin_for_edge_length(double edge_length_mm);

struct BinSizeOptions {
  double tolerance_mm = 0.05;  // ε
  // The curvature that sets B is the mean over a region of this many points (the point and its
  // nearest), at least three quarters of them regular: one noisy fit, a spike or a crease does not set
  // the bin size of the whole scan. 64 at k = 25: about 2.5 independent fits, half the noise of one.
  int region_points = 64;
  // A region's |k1| counts only when at least this many of its standard errors (the fits' mean σ over
  // √(independent fits)) from 0: below it, the curvature is the scan's noise, not the surface's. 4, not
  // 3: a scan has 10⁴ regions, and the most curved of them at 3σ would often be noise.
  double significance = 4;
  // With no significant curvature (a flat scan) or a curvature that would allow coarser bins, B is
  // capped at the larger of spacing_cap × the median raw spacing and size_cap × the cloud's
  // bounding-box diagonal, so that every face keeps points near its edges for the triangulation.
  double spacing_cap = 4;
  double size_cap = 0.02;
  // The sampling floor: where no measured curvature sets B (the noise or the cap does), B is at least
  // what gives a bin this many raw points on average where the scan is sparsest (the `sparse_quantile`
  // of the points' local densities). A bin of area B² over a random sample of density ρ is empty with
  // probability e^(−ρB²): at 6, 0.25 %, lone gaps the triangulation bridges; at the 1.5–3 a noise-set
  // bin held on a merged random scan, 5–20 %, and every cluster of empty bins was a pinhole.
  double samples_per_bin = 6;
  double sparse_quantile = 0.1;
};

struct BinSize {
  double bin_mm = 0;                 // B
  double edge_length_mm = 0;         // Ω = √6·B (kMaxEdgeBins)
  double second_derivative_sum = 0;  // M1 + 2M2 + M3 in the principal frame (|k1| + |k2|), 1/mm, at `point`
  // The fit (index into the cloud) whose region set B; 0 (and `where` zero) when the cap or the noise
  // set it: on a noisy scan a curvature below `significance` region standard errors is not told from
  // noise, so B also never exceeds what that curvature (k1 then, as a sphere's) allows.
  std::size_t point = 0;
  Vec3 where = Vec3::Zero();         // that fit's origin, mm
  double k1 = 0;                     // its region's mean curvature, 1/mm, signed for the fit's normal there
  std::size_t regular_points = 0;    // regular fits in the cloud
  bool capped = false;               // B is the cap, not ε's
  bool noise_limited = false;        // B is what the curvature the noise can hide allows
  double median_spacing_mm = 0;      // of the raw cloud
  double sparse_density_per_mm2 = 0; // points per mm² of surface where the scan is sparsest (see options)
  double sampling_floor_mm = 0;      // √(samples_per_bin / sparse density)
  bool sampling_limited = false;     // B was raised to the sampling floor
  std::string source;                // for the report, e.g. "tolerance 0.050 mm at the most curved region near (…) mm, …"
};

// The surface density of the raw points around each regular fit, k / (π·r_k²) with r_k the distance to
// its k-th neighbour, at `quantile` (0.1: where the scan is sparsest, not its single sparsest spot).
// 0 without regular fits.
double sparse_density(const std::vector<LocalSurface>& fits, double quantile);

// Median distance from a point to its nearest other point (sampled on at most 20,000 evenly spaced
// points; deterministic). 0 for fewer than two distinct points.
double median_spacing(const Points& points, const CloudIndex& index);

// B for ε over the cloud `points` with its fits and index. Deterministic; on both cores.
// Throws std::invalid_argument on a tolerance that is not positive and finite.
BinSize bin_size_for_tolerance(const Points& points, const std::vector<LocalSurface>& fits, const CloudIndex& index,
                               const BinSizeOptions& options = {});

struct DensityCheck {
  bool too_sparse = false;          // the raw spacing exceeds the bin ε allows
  double tolerance_needed_mm = 0;   // the ε whose bin equals the raw spacing (when too sparse)
};

// Whether the scan is too sparse for ε: bins smaller than the raw spacing keep every point and the
// mesh's edges, the raw spacing, are longer than ε allows. Ω² grows with ε, so ε·(spacing / B)² would do.
DensityCheck check_density(const BinSize& bin, double tolerance_mm);

}  // namespace cmm::geometry
