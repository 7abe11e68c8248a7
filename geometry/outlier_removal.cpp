// Mean k-NN distance per point in parallel, then μ and σ in index order, then the threshold; a point
// beyond it is looked at again against the plane of its neighbours.
#include "geometry/outlier_removal.hpp"

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace cmm::geometry {

namespace {
constexpr int block = 1 << 15;  // points between polls of the cancel check

// A point on the border of the scanned surface has neighbours on one side only, so its mean distance to
// them is up to twice theirs (a quarter disk at a face's corner) and may pass μ + ratio·σ where the scan
// is dense and even; it lies on the plane of its neighbours within their own scatter about it. A stray
// lies off that plane or much farther from its neighbours than they lie from theirs.
bool on_its_neighbours_surface(const Points& points, const CloudIndex& index, const std::vector<double>& mean, int i,
                               std::size_t k, std::vector<int>& ids, std::vector<double>& squared) {
  const Vec3 p = points.row(i).transpose();
  index.nearest(p, k + 1, ids, squared);
  if (ids.size() < 4) return false;
  std::vector<double> theirs;
  Vec3 centre = Vec3::Zero();
  for (std::size_t j = 1; j < ids.size(); ++j) {
    theirs.push_back(mean[static_cast<std::size_t>(ids[j])]);
    centre += points.row(ids[j]).transpose() / static_cast<double>(ids.size() - 1);
  }
  std::nth_element(theirs.begin(), theirs.begin() + static_cast<std::ptrdiff_t>(theirs.size() / 2), theirs.end());
  if (mean[static_cast<std::size_t>(i)] > 2 * theirs[theirs.size() / 2]) return false;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (std::size_t j = 1; j < ids.size(); ++j) {
    const Vec3 d = points.row(ids[j]).transpose() - centre;
    scatter += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  const Vec3 normal = eigen.eigenvectors().col(0);
  const double rms = std::sqrt(std::max(0.0, eigen.eigenvalues()(0)) / static_cast<double>(ids.size() - 1));
  // One-sided: the neighbours' centre lies off the point along the surface by a good part of their mean
  // distance (0.64 of it at a straight border, about 0.2 amid a surface sampled at random, where a sparse
  // patch is PCL's to judge as before).
  const Vec3 off = centre - p;
  const double beside = (off - off.dot(normal) * normal).norm();
  return beside >= 0.35 * mean[static_cast<std::size_t>(i)] &&
         std::abs((p - centre).dot(normal)) <= 3 * rms + 1e-9 * mean[static_cast<std::size_t>(i)];
}
}  // namespace

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
  std::vector<char> keep(static_cast<std::size_t>(n), 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 4096), [&](const tbb::blocked_range<int>& r) {
    std::vector<int> ids;
    std::vector<double> squared;
    for (int i = r.begin(); i < r.end(); ++i) {
      const auto at = static_cast<std::size_t>(i);
      // Only within 2 μ: a border of an evenly sampled face lies at about 1.4 μ (half a disk of
      // neighbours), a face's corner at 2 μ; beyond, a sparse fringe of one view (deep in the plate's
      // slot, scanned at a grazing angle) came back as specks of their own that no gap closing joined.
      keep[at] = mean[at] <= threshold ||
                 (mean[at] <= 2 * mu && on_its_neighbours_surface(points, index, mean, i, k, ids, squared));
    }
  });
  std::vector<int> inliers;
  inliers.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    if (keep[static_cast<std::size_t>(i)]) inliers.push_back(i);
  return inliers;
}

}  // namespace cmm::geometry
