// CloudIndex on nanoflann's KDTreeSingleIndexAdaptor, reading the Points matrix in place.
#include "geometry/cloud_index.hpp"

#include <nanoflann.hpp>

namespace cmm::geometry {

namespace {

struct PointsAdaptor {
  const Points* points;
  std::size_t kdtree_get_point_count() const { return static_cast<std::size_t>(points->rows()); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*points)(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(dim)); }
  template <class Box>
  bool kdtree_get_bbox(Box&) const { return false; }
};

using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>, PointsAdaptor, 3, int>;

}  // namespace

struct CloudIndex::Tree {
  explicit Tree(const Points& points) : adaptor{&points}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {}
  PointsAdaptor adaptor;
  KdTree tree;
};

CloudIndex::CloudIndex(const Points& points) : tree_(std::make_unique<Tree>(points)) {}
CloudIndex::~CloudIndex() = default;
CloudIndex::CloudIndex(CloudIndex&&) noexcept = default;
CloudIndex& CloudIndex::operator=(CloudIndex&&) noexcept = default;

std::size_t CloudIndex::size() const { return tree_->adaptor.kdtree_get_point_count(); }

void CloudIndex::nearest(const Vec3& query, std::size_t k, std::vector<int>& ids, std::vector<double>& squared) const {
  k = std::min(k, size());
  ids.resize(k);
  squared.resize(k);
  if (k == 0) return;
  const std::size_t found = tree_->tree.knnSearch(query.data(), k, ids.data(), squared.data());
  ids.resize(found);
  squared.resize(found);
}

std::vector<int> CloudIndex::nearest(const Vec3& query, std::size_t k) const {
  std::vector<int> ids;
  std::vector<double> squared;
  nearest(query, k, ids, squared);
  return ids;
}

std::vector<int> CloudIndex::within(const Vec3& query, double radius) const {
  std::vector<std::pair<int, double>> matches;
  nanoflann::SearchParams params;
  params.sorted = true;
  tree_->tree.radiusSearch(query.data(), radius * radius, matches, params);
  std::vector<int> ids;
  ids.reserve(matches.size());
  for (const auto& m : matches) ids.push_back(m.first);
  return ids;
}

}  // namespace cmm::geometry
