// Statistical outlier removal (PCL's StatisticalOutlierRemoval): a point whose mean distance to its
// k nearest neighbours lies beyond μ + ratio·σ of all those means is a stray, not the surface.
#pragma once

#include <vector>

#include "geometry/cancellation.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct OutlierOptions {
  int neighbours = 25;   // k, the point itself not counted
  double std_ratio = 3;  // PCL's stddev_mult
  CancelCheck cancel;    // polled between blocks of points
};

// Indices into `points` of the inliers, ascending; all of them when the cloud has k or fewer points.
// `index` is over `points`. On both cores; the same result on any number of threads (the means are
// summed in index order).
std::vector<int> statistical_inliers(const Points& points, const CloudIndex& index, const OutlierOptions& options = {});

}  // namespace cmm::geometry
