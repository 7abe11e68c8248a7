// A uniform grid over a fixed point set for fixed-radius neighbour queries: the triangulation's
// front asks the same small radius hundreds of thousands of times, where a grid beats a k-d tree.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

class PointGrid {
 public:
  // Keeps a reference to `points`: they must outlive the grid and not change. `cell` > 0.
  PointGrid(const Points& points, double cell);

  // Every point within `radius` of `query` (its squared distance with it), cell by cell and in index
  // order within a cell: deterministic, not sorted by distance.
  template <class Visit>
  void for_each_within(const Vec3& query, double radius, Visit&& visit) const {
    const double r2 = radius * radius;
    const Eigen::Vector3i lo = cell_of(query - Vec3::Constant(radius)).cwiseMax(0);
    const Eigen::Vector3i hi = cell_of(query + Vec3::Constant(radius)).cwiseMin(dims_ - Eigen::Vector3i::Ones());
    for (int x = lo.x(); x <= hi.x(); ++x)
      for (int y = lo.y(); y <= hi.y(); ++y)
        for (int z = lo.z(); z <= hi.z(); ++z) {
          const auto [begin, end] = cell_range(x, y, z);
          for (int k = begin; k < end; ++k) {
            const int id = order_[k];
            const double d2 = (points_->row(id).transpose() - query).squaredNorm();
            if (d2 <= r2) visit(id, d2);
          }
        }
  }

  std::vector<int> within(const Vec3& query, double radius) const;

 private:
  Eigen::Vector3i cell_of(const Vec3& p) const;
  std::int64_t linear(int x, int y, int z) const { return (std::int64_t(x) * dims_.y() + y) * dims_.z() + z; }
  std::pair<int, int> cell_range(int x, int y, int z) const {
    const std::int64_t key = linear(x, y, z);
    if (!dense_.empty()) return {dense_[key], dense_[key + 1]};
    const auto it = sparse_.find(key);
    return it == sparse_.end() ? std::pair<int, int>{0, 0} : it->second;
  }

  const Points* points_;
  double inverse_cell_;
  Vec3 origin_;
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  std::vector<int> order_;  // point ids grouped by cell
  // Cell → [begin, end) in order_: a flat array when the box has few enough cells, else a hash map.
  std::vector<int> dense_;
  std::unordered_map<std::int64_t, std::pair<int, int>> sparse_;
};

}  // namespace cmm::geometry
