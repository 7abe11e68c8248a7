// Points are bucketed once by sorting on their cell index; queries visit the cells the query's
// bounding cube touches, clipped to the points' bounding box.
#include "geometry/point_grid.hpp"

#include <algorithm>
#include <cmath>

namespace cmm::geometry {

PointGrid::PointGrid(const Points& points, double cell) : points_(&points), inverse_cell_(1 / cell), origin_(Vec3::Zero()) {
  Vec3 lo = Vec3::Constant(HUGE_VAL), hi = Vec3::Constant(-HUGE_VAL);
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    if (points.row(i).allFinite()) lo = lo.cwiseMin(points.row(i).transpose()), hi = hi.cwiseMax(points.row(i).transpose());
  if (!(lo.x() <= hi.x())) return;  // no finite point: every query finds nothing
  origin_ = lo;
  // Far-flung points (a stray, a huge box) would make more cells than an index can hold: coarser cells.
  const double largest = ((hi - lo) * inverse_cell_).maxCoeff();
  if (largest > 1e6) inverse_cell_ *= 1e6 / largest;
  dims_ = ((hi - lo) * inverse_cell_).array().floor().cast<int>() + 1;
  std::vector<std::pair<std::int64_t, int>> keyed;
  keyed.reserve(static_cast<std::size_t>(points.rows()));
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    if (!points.row(i).allFinite()) continue;  // never found
    const Eigen::Vector3i c = cell_of(points.row(i).transpose()).cwiseMax(0).cwiseMin(dims_ - Eigen::Vector3i::Ones());
    keyed.emplace_back(linear(c.x(), c.y(), c.z()), static_cast<int>(i));
  }
  std::sort(keyed.begin(), keyed.end());
  order_.reserve(keyed.size());
  for (const auto& k : keyed) order_.push_back(k.second);
  const double cells = double(dims_.x()) * dims_.y() * dims_.z();
  if (cells <= std::max(65536.0, 8.0 * static_cast<double>(points.rows()))) {
    dense_.assign(static_cast<std::size_t>(cells) + 1, 0);
    for (const auto& k : keyed) ++dense_[static_cast<std::size_t>(k.first) + 1];
    for (std::size_t i = 1; i < dense_.size(); ++i) dense_[i] += dense_[i - 1];
    return;
  }
  for (std::size_t i = 0; i < keyed.size();) {
    std::size_t j = i;
    while (j < keyed.size() && keyed[j].first == keyed[i].first) ++j;
    sparse_.emplace(keyed[i].first, std::pair<int, int>(static_cast<int>(i), static_cast<int>(j)));
    i = j;
  }
}

Eigen::Vector3i PointGrid::cell_of(const Vec3& p) const {
  // Clamped before the cast (NaN to −1): a query far outside the box must not overflow.
  Eigen::Vector3i c;
  for (int k = 0; k < 3; ++k) {
    const double v = std::floor((p(k) - origin_(k)) * inverse_cell_);
    c(k) = v >= -1 ? (v <= 2e6 ? static_cast<int>(v) : 2000000) : -1;
  }
  return c;
}

std::vector<int> PointGrid::within(const Vec3& query, double radius) const {
  std::vector<int> ids;
  for_each_within(query, radius, [&](int id, double) { ids.push_back(id); });
  return ids;
}

}  // namespace cmm::geometry
