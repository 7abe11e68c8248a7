// The model against the plate it stands on, as given and at each unit factor; see model_units.hpp.
#include "planner/model_units.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {

using Vec3 = Eigen::Vector3d;

struct UnitFactor {
  double factor;      // the coordinates times this stand
  const char* guess;  // what that says about the model
};

// The factors tried, and what each suggests. > 1: the model is too small by it.
const UnitFactor unit_factors[] = {
    {25.4, "a model in inches"},         {10, "a model in centimetres"},
    {1000, "a model in metres"},         {1 / 25.4, "a model in mm scaled as if in inches"},
    {1 / 10.0, "a model in mm scaled as if in centimetres"}, {1 / 1000.0, "a model in mm scaled as if in metres"},
};

// 25.4, 10, 1000 (the factor or its inverse, whichever is > 1), as the messages write it.
std::string factor_text(double factor) {
  const double f = factor >= 1 ? factor : 1 / factor;
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", std::round(f * 10) / 10);
  return buffer;
}

std::string scale_text(double scale) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", scale);
  return buffer;
}

// The q-quantile of `values` (0 ≤ q ≤ 1), reordering them.
double quantile(std::vector<double>& values, double q) {
  const auto k = static_cast<std::ptrdiff_t>(std::floor(q * static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[static_cast<std::size_t>(k)];
}

// Every n-th point, so that at most `max_points` are looked at.
std::vector<Vec3> sample(const geometry::Points& points, std::size_t max_points) {
  const auto n = static_cast<std::size_t>(points.rows());
  const std::size_t stride = std::max<std::size_t>(1, (n + max_points - 1) / std::max<std::size_t>(1, max_points));
  std::vector<Vec3> out;
  out.reserve(n / stride + 1);
  for (std::size_t i = 0; i < n; i += stride) out.push_back(points.row(static_cast<Eigen::Index>(i)).transpose());
  return out;
}

// The bounding box's size without the outlier fraction's strays at either end of each axis.
Vec3 robust_extent(const std::vector<Vec3>& points, double outliers) {
  Vec3 extent;
  std::vector<double> column(points.size());
  for (int axis = 0; axis < 3; ++axis) {
    for (std::size_t i = 0; i < points.size(); ++i) column[i] = points[i][axis];
    const double lo = quantile(column, outliers / 2), hi = quantile(column, 1 - outliers / 2);
    extent[axis] = hi - lo;
  }
  return extent;
}

std::string extent_text(const Vec3& e) {
  return fixed(e.x(), e.maxCoeff() < 10 ? 3 : 1) + " × " + fixed(e.y(), e.maxCoeff() < 10 ? 3 : 1) + " × " +
         fixed(e.z(), e.maxCoeff() < 10 ? 3 : 1) + " mm";
}

// How the model, its coordinates times `factor`, stands: empty when it does, else why not.
struct Standing {
  bool stands = false;
  std::string why;
};

class PlateTest {
 public:
  PlateTest(const std::vector<Vec3>& points_S, const Vec3& extent, const description::Plate& plate,
            const std::optional<Eigen::Isometry3d>& T_S_P, const ModelUnitsOptions& options)
      : extent_(extent), plate_(plate), options_(options) {
    double shortest = std::numeric_limits<double>::infinity();
    for (int id = 1; id <= plate.corner_count(); ++id) {
      shortest = std::min(shortest, (plate.corner(plate.next(id)) - plate.corner(id)).norm());
      for (int other = id + 1; other <= plate.corner_count(); ++other)
        diagonal_ = std::max(diagonal_, (plate.corner(other) - plate.corner(id)).norm());
    }
    smallest_part_mm_ = options.min_part_fraction * shortest;
    if (!T_S_P) return;
    // In P, the coordinates times f are f·(R p) + t: the rotated points once, the factor per test.
    const Eigen::Isometry3d T_P_S = T_S_P->inverse();
    translation_ = T_P_S.translation();
    rotated_.reserve(points_S.size());
    for (const Vec3& p : points_S) rotated_.push_back(T_P_S.linear() * p);
    corners_known_ = true;
  }

  double smallest_part_mm() const { return smallest_part_mm_; }

  Standing at(double factor) const {
    const double largest = factor * extent_.maxCoeff();
    if (largest < smallest_part_mm_)
      return {false, "it is only " + fixed(largest, largest < 10 ? 3 : 1) + " mm across, less than the " +
                         fixed(smallest_part_mm_, 1) + " mm a part on this plate has (a tenth of its shortest side)"};
    if (!corners_known_) {
      if (largest > diagonal_ + 2 * options_.margin_mm)
        return {false, "it is " + fixed(largest, 1) + " mm across, more than the plate's diagonal of " +
                           fixed(diagonal_, 1) + " mm"};
      return {true, ""};
    }
    // Per point: how far beyond the polygon's sides (and which side), and below the plate's bottom.
    const int n = plate_.corner_count();
    std::vector<double> beyond(rotated_.size()), below(rotated_.size());
    std::vector<int> side(rotated_.size());
    std::size_t off = 0;
    for (std::size_t i = 0; i < rotated_.size(); ++i) {
      const Vec3 q = factor * rotated_[i] + translation_;
      double worst = -std::numeric_limits<double>::infinity();
      int worst_side = 1;
      for (int id = 1; id <= n; ++id) {
        const Vec3 normal = description::side_normal(plate_, id);
        const double d = normal.head<2>().dot((q - plate_.corner(id)).head<2>());
        if (d > worst) worst = d, worst_side = id;
      }
      beyond[i] = worst;
      side[i] = worst_side;
      below[i] = (plate_.top_z() - plate_.thickness_mm) - q.z();
      off += worst > options_.margin_mm || below[i] > options_.margin_mm;
    }
    if (static_cast<double>(off) <= options_.outlier_fraction * static_cast<double>(rotated_.size())) return {true, ""};
    // The why: the farthest reach beyond a side, the strays left out, or the depth below the plate.
    std::vector<std::size_t> order(rotated_.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    const auto k = static_cast<std::ptrdiff_t>(std::floor((1 - options_.outlier_fraction) * static_cast<double>(order.size() - 1)));
    std::nth_element(order.begin(), order.begin() + k, order.end(),
                     [&](std::size_t a, std::size_t b) { return beyond[a] < beyond[b]; });
    const std::size_t far = order[static_cast<std::size_t>(k)];
    std::string why;
    if (beyond[far] > options_.margin_mm) {
      const int a = side[far], b = plate_.next(side[far]);
      why = "its points reach " + fixed(beyond[far], 1) + " mm beyond the plate's side from corner " + std::to_string(a) +
            " to corner " + std::to_string(b);
    }
    std::vector<double> depth = below;
    const double deep = quantile(depth, 1 - options_.outlier_fraction);
    if (deep > options_.margin_mm)
      why += (why.empty() ? "its points reach " : ", and ") + fixed(deep, 1) + " mm below the plate's bottom";
    return {false, why.empty() ? "more than " + fixed(100 * options_.outlier_fraction, 0) +
                                     " % of its points are off the plate" : why};
  }

 private:
  Vec3 extent_;
  const description::Plate& plate_;
  const ModelUnitsOptions& options_;
  double diagonal_ = 0, smallest_part_mm_ = 0;
  bool corners_known_ = false;
  std::vector<Vec3> rotated_;
  Vec3 translation_ = Vec3::Zero();
};

}  // namespace

ModelUnits check_model_units(const geometry::Points& points_S, double scale, const std::string& source,
                             const description::Plate& plate, const std::optional<Eigen::Isometry3d>& T_S_P,
                             const ModelUnitsOptions& options) {
  ModelUnits u;
  u.corners_known = T_S_P.has_value();
  if (points_S.rows() == 0 || !points_S.allFinite()) return u;  // the model limits say what is wrong with it
  const std::vector<Vec3> points = sample(points_S, options.max_points);
  u.extent_mm = robust_extent(points, options.outlier_fraction);
  if (!u.corners_known)
    u.notes.push_back("the model's position on the plate was not checked, only its size: the request gives no "
                      "plate corners in S (a registration)");
  const PlateTest test(points, u.extent_mm, plate, T_S_P, options);
  const Standing given = test.at(1);
  if (given.stands) return u;
  u.stands = false;
  // Of the factors that make it stand, the one that makes it largest: a part in inches also stands
  // at a tenth of its true size when it is small against the plate, never at more than its size.
  const UnitFactor* best = nullptr;
  for (const UnitFactor& f : unit_factors)
    if (test.at(f.factor).stands && (!best || f.factor > best->factor)) best = &f;
  const std::string as_given = "as given (scale " + scale_text(scale) + ") it spans " + extent_text(u.extent_mm) + " and " +
                               given.why;
  const std::string override_text =
      "if it really is so, say so with --units-checked (\"units_checked\": true) or an explicit --scale";
  if (best) {
    u.factor = best->factor;
    const std::string where = u.corners_known ? "stands on the plate inside its corners" : "is a plausible size for the plate";
    u.problem = source + ": the model is " + factor_text(best->factor) + "× " + (best->factor > 1 ? "smaller" : "larger") +
                " than the plate it stands on: " + best->guess + "? use --scale " + scale_text(scale * best->factor) +
                " (\"scale\": " + scale_text(scale * best->factor) + "); " + as_given + "; scaled by " +
                scale_text(best->factor) + " it " + where + "; " + override_text;
    return u;
  }
  if (!u.corners_known) {
    u.notes.push_back(source + ": " + as_given + "; no unit factor (25.4, 10, 1000) makes it a plausible size, so it is "
                      "not refused without the plate's corners");
    return u;
  }
  u.problem = source + ": the model does not stand on the plate inside its corners: " + as_given +
              "; no unit factor (25.4, 10, 1000) puts it there: are the scan corners and the model in the same frame S? " +
              override_text;
  return u;
}

}  // namespace cmm::planner
