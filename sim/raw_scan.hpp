// A synthesized laser scan of a true part: the merged cloud of several views, with noise, each
// view's registration error and stray points, together with the truth every point came from. The
// sampling, the noise model and each view's coverage and density are options, so that one part can be
// scanned the ways real scanners and merging tools sample it.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/mesh.hpp"
#include "geometry/point_cloud.hpp"
#include "sim/scan_views.hpp"
#include "sim/view_coverage.hpp"
#include "sim/visibility.hpp"

namespace cmm::sim {

// Where on a face a view's points fall (scan_sampling.hpp has the grid and Poisson samplers).
enum class ScanSampling {
  random,   // area-uniform at random: area · density / spacing² per face a view faces, whatever the incidence
  grid,     // a scanner's raster: parallel beams on a square lattice of pitch spacing / √density across the
            // view's image, each onto the first face it meets; density on a face falls as cos(incidence)
  poisson,  // a merging tool's resampling: a Poisson-disk set over the union of what the views see, no two
            // points nearer than kPoissonRadius · spacing (about 1 / spacing² points per mm²)
};

enum class ScanNoise {
  beam,       // Gaussian along the view direction (a laser's range error)
  isotropic,  // Gaussian, σ per coordinate (a cloud smoothed or resampled after the merge)
};

// "random", "grid", "poisson"; "beam", "isotropic": the names cmm-scan and the truth files use.
const char* to_string(ScanSampling sampling);
const char* to_string(ScanNoise noise);

struct RawScanOptions {
  double spacing_mm = 0.5;        // sets the density: about 1 / spacing² points per mm², as ScanSampling says
  double noise_sigma_mm = 0.05;   // Gaussian; how it is applied is noise_model
  std::vector<ScanView> views = default_views();
  double max_incidence_deg = kDefaultMaxIncidenceDeg;
  double stray_fraction = 0.002;  // chance that a sample is a stray instead, in [0, 1)
  std::uint64_t seed = 1;
  ScanSampling sampling = ScanSampling::random;
  ScanNoise noise_model = ScanNoise::beam;
  // In (0, 1]: the share of the surface it sees that each view keeps, as one band across its image
  // (view_coverage.hpp); 1 keeps whole views and draws nothing, so scans stay as they were.
  double view_coverage = 1;
  // Empty (every view 1) or one factor per view on its density of 1 / spacing² (random, grid); for
  // poisson, whose merged density is one, the odds a point where views overlap is credited to each.
  std::vector<double> view_density = {};
};

// Per point of the cloud, in cloud order.
struct RawScanTruth {
  std::vector<int> view;  // index into RawScanOptions::views
  std::vector<int> face;  // scene face the sample lies on; −1 for a stray
  // Scene frame, before noise and the view's registration error: the true surface point, or for a
  // stray where it was drawn.
  geometry::Points surface_points;
  std::vector<bool> stray;
  // Per view, the band of the scene it kept (a whole view when view_coverage is 1).
  std::vector<CoverageBand> coverage;
};

struct RawScan {
  geometry::PointCloud cloud;  // points and unit normals, as the views reported them
  RawScanTruth truth;
};

// Each view samples the faces it faces as `sampling` says and keeps the samples it sees within its
// coverage band; a face seen by several views gets points from each (poisson: one merged set, each point
// credited to one view that sees it). A kept sample becomes, with probability stray_fraction, a stray
// drawn uniformly in the scene's bounding box grown by 10 % (its normal faces the scanner); otherwise it
// moves by the noise and carries the face's normal. Both then go through the view's registration error.
// Points come in view order (poisson: grouped by view too). Same options, same scan; with the default
// sampling, noise, coverage and density a seed gives the same scan as before those options existed.
// Throws std::invalid_argument naming the bad option.
RawScan synthesize_raw_scan(const geometry::TriangleMesh& scene, const RawScanOptions& options = {});

}  // namespace cmm::sim
