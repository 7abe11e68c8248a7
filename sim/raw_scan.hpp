// A synthesized laser scan of a true part: the merged cloud of several views, with beam noise, each
// view's registration error and stray points, together with the truth every point came from.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/mesh.hpp"
#include "geometry/point_cloud.hpp"
#include "sim/scan_views.hpp"
#include "sim/visibility.hpp"

namespace cmm::sim {

struct RawScanOptions {
  double spacing_mm = 0.5;        // area / spacing² samples per face a view faces, whatever the incidence
  double noise_sigma_mm = 0.05;   // Gaussian, along the beam
  std::vector<ScanView> views = default_views();
  double max_incidence_deg = kDefaultMaxIncidenceDeg;
  double stray_fraction = 0.002;  // chance that a sample is a stray instead, in [0, 1)
  std::uint64_t seed = 1;
};

// Per point of the cloud, in cloud order.
struct RawScanTruth {
  std::vector<int> view;  // index into RawScanOptions::views
  std::vector<int> face;  // scene face the sample lies on; −1 for a stray
  // Scene frame, before noise and the view's registration error: the true surface point, or for a
  // stray where it was drawn.
  geometry::Points surface_points;
  std::vector<bool> stray;
};

struct RawScan {
  geometry::PointCloud cloud;  // points and unit normals, as the views reported them
  RawScanTruth truth;
};

// Each view samples every face it faces area-uniformly (area / spacing² points on average) and keeps the
// samples it sees; a face seen by several views gets points from each. A kept sample becomes, with
// probability stray_fraction, a stray drawn uniformly in the scene's bounding box grown by 10 % (its
// normal faces the scanner); otherwise it moves by the beam noise along the view direction and carries
// the face's normal. Both then go through the view's registration error. Same options, same scan.
// Throws std::invalid_argument naming the bad option.
RawScan synthesize_raw_scan(const geometry::TriangleMesh& scene, const RawScanOptions& options = {});

}  // namespace cmm::sim
