// Statistical outlier removal (PCL's StatisticalOutlierRemoval): a point whose mean distance to its
// k nearest neighbours lies beyond μ + ratio·σ of all those means is a stray, not the surface, unless it
// lies on its neighbours' plane (within 3 times their robust scatter about it) and at most twice as far
// from them as they lie from theirs (median). That is the border of an evenly scanned surface, which
// PCL's filter eats into where there are few strays and μ + 3σ is tight (17 of the 373 points within
// 0.3 mm of a Ø6 opening at 60 points per mm²), or a face scanned far more sparsely than the rest, which
// it takes nearly whole (524 of 800 points at 2 per mm² beside 25).
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
