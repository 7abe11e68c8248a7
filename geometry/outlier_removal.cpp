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

// Beyond μ + ratio·σ a point may still be the surface: a border of an evenly scanned face (neighbours on
// one side only, so its mean distance to them is up to twice theirs, a quarter disk at a face's corner) or
// a face scanned far more sparsely than the rest (a side one sparse view saw, the lower wall of a bore:
// μ and σ are the dense faces', and PCL's filter took 524 of 800 points of a face at 2 points per mm²
// beside one at 25). Either lies on the plane of its neighbours within their own scatter about it and no
// farther from them than twice as far as they lie from theirs (median). A stray lies off that plane or
// much farther. The scatter is the neighbours' median distance from their plane (×1.4826, σ for Gaussian
// noise), so that another stray among them does not widen it.
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
  const auto middle = [](std::vector<double>& v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  if (mean[static_cast<std::size_t>(i)] > 2 * middle(theirs)) return false;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (std::size_t j = 1; j < ids.size(); ++j) {
    const Vec3 d = points.row(ids[j]).transpose() - centre;
    scatter += d * d.transpose();
  }
  const Vec3 normal = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvectors().col(0);
  std::vector<double> off;
  for (std::size_t j = 1; j < ids.size(); ++j) off.push_back(std::abs((points.row(ids[j]).transpose() - centre).dot(normal)));
  return std::abs((p - centre).dot(normal)) <= 3 * 1.4826 * middle(off) + 1e-9 * mean[static_cast<std::size_t>(i)];
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
      // Beyond 2 μ too (once left to PCL's rule: a sparse fringe of one view deep in the plate's slot came
      // back as specks; region growing now drops a component that small, and meshes a sparse face at its
      // own spacing).
      keep[at] = mean[at] <= threshold || on_its_neighbours_surface(points, index, mean, i, k, ids, squared);
    }
  });
  std::vector<int> inliers;
  inliers.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    if (keep[static_cast<std::size_t>(i)]) inliers.push_back(i);
  return inliers;
}

}  // namespace cmm::geometry
