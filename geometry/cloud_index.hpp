// k nearest neighbours and radius search over a point set, on nanoflann's k-d tree: the one
// neighbourhood query of the scan front end (fitting, outlier removal, triangulation).
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

class CloudIndex {
 public:
  // Keeps a reference to `points`: they must outlive the index and not change.
  explicit CloudIndex(const Points& points);
  ~CloudIndex();
  CloudIndex(CloudIndex&&) noexcept;
  CloudIndex& operator=(CloudIndex&&) noexcept;

  std::size_t size() const;
  // The k points nearest `query` (fewer when the set is smaller), nearest first; `query` itself when
  // it is a point of the set. Safe to call from several threads at once.
  std::vector<int> nearest(const Vec3& query, std::size_t k) const;
  // Same, with squared distances, into caller-owned buffers (no allocation once they are large enough).
  void nearest(const Vec3& query, std::size_t k, std::vector<int>& ids, std::vector<double>& squared) const;
  // Every point within `radius` of `query`, nearest first.
  std::vector<int> within(const Vec3& query, double radius) const;

 private:
  struct Tree;
  std::unique_ptr<Tree> tree_;
};

}  // namespace cmm::geometry
