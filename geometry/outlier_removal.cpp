// Mean k-NN distance per point in parallel, then μ and σ in index order, then the threshold.
#include "geometry/outlier_removal.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace cmm::geometry {

namespace {
constexpr int block = 1 << 15;  // points between polls of the cancel check
}

std::vector<int> statistical_inliers(const Points& points, const CloudIndex& index, const OutlierOptions& options) {
  const int n = static_cast<int>(points.rows());
  const auto k = static_cast<std::size_t>(std::max(options.neighbours, 1));
  std::vector<int> all(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) all[static_cast<std::size_t>(i)] = i;
  if (static_cast<std::size_t>(n) <= k) return all;

  std::vector<double> mean(static_cast<std::size_t>(n), 0);
  for (int start = 0; start < n; start += block) {
    options.cancel.throw_if_requested("outlier removal");
    tbb::parallel_for(tbb::blocked_range<int>(start, std::min(n, start + block), 512), [&](const tbb::blocked_range<int>& r) {
      std::vector<int> ids;
      std::vector<double> squared;
      for (int i = r.begin(); i < r.end(); ++i) {
        // k + 1 with the point itself first, as PCL asks; a duplicate of it may come first instead,
        // at the same distance 0, so the nearest is dropped whichever it is.
        index.nearest(points.row(i).transpose(), k + 1, ids, squared);
        double sum = 0;
        for (std::size_t j = 1; j < squared.size(); ++j) sum += std::sqrt(squared[j]);
        mean[static_cast<std::size_t>(i)] = sum / static_cast<double>(squared.size() - 1);
      }
    });
  }
  double sum = 0, sum_squares = 0;
  for (double m : mean) sum += m, sum_squares += m * m;
  const double mu = sum / n;
  const double sigma = std::sqrt(std::max(0.0, (sum_squares - sum * sum / n) / (n - 1)));
  const double threshold = mu + options.std_ratio * sigma;
  std::vector<int> inliers;
  inliers.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    if (mean[static_cast<std::size_t>(i)] <= threshold) inliers.push_back(i);
  return inliers;
}

}  // namespace cmm::geometry
