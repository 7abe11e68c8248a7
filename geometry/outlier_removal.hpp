// Statistical outlier removal (PCL's StatisticalOutlierRemoval): a point whose mean distance to its
// k nearest neighbours lies beyond μ + ratio·σ of all those means is a stray, not the surface, unless its
// neighbours lie to one side of it (their centre over a third of their mean distance off it along their
// plane), it lies on their plane (within 3 times their RMS about it), at most twice as far from them as
// they lie from theirs (median) and at most 2 μ: that is the border of an evenly scanned surface, which
// PCL's filter eats into where there are few strays and μ + 3σ is tight (17 of the 373 points within
// 0.3 mm of a Ø6 opening at 60 points per mm²), and every opening would come out that much larger.
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
