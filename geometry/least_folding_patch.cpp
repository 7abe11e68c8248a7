// Liepa's dynamic programme over the loop's sub-polygons: the best patch of loop[i..j] closed by the
// diagonal (i, j) is a triangle (i, k, j) plus the best patches of loop[i..k] and loop[k..j], so each
// sub-polygon is solved once from the shorter ones.
#include "geometry/least_folding_patch.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace cmm::geometry {
namespace {

struct Weight {
  double angle = 0;  // the largest dihedral inside the sub-patch and against its rim
  double area = 0;
  double longest = 0;  // the longest diagonal
  bool feasible = false;
};

// Lexicographic, each within rounding: a flat loop's triangulations all fold 0° and cover one area, and
// then the one with the shortest longest diagonal is the one a refinement needs least to cut.
bool better(const Weight& a, const Weight& b) {
  if (!b.feasible) return a.feasible;
  if (!a.feasible) return false;
  if (std::abs(a.angle - b.angle) > 1e-9) return a.angle < b.angle;
  if (std::abs(a.area - b.area) > 1e-9 * std::max(a.area, b.area)) return a.area < b.area;
  return a.longest < b.longest;
}

// A zero normal is a side no facet lies beside yet: it turns nothing.
double angle_between(const Vec3& a, const Vec3& b) { return b.isZero() ? 0.0 : std::acos(std::clamp(a.dot(b), -1.0, 1.0)); }

}  // namespace

std::optional<LeastFoldingPatch> least_folding_patch(const std::vector<Vec3>& loop, const std::vector<Vec3>& rim_normals,
                                                     const std::function<bool(int, int)>& may_join) {
  const int n = static_cast<int>(loop.size());
  if (n < 3 || rim_normals.size() != loop.size()) return std::nullopt;
  const auto at = [n](int i, int j) { return static_cast<std::size_t>(i) * static_cast<std::size_t>(n) + static_cast<std::size_t>(j); };
  std::vector<Weight> best(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
  std::vector<int> apex(best.size(), -1);
  std::vector<Vec3> normal(best.size(), Vec3::Zero());  // of the triangle (i, apex, j)
  for (int i = 0; i + 1 < n; ++i) best[at(i, i + 1)] = Weight{0, 0, 0, true};
  // The facet beside the diagonal or side (i, j) of the sub-polygon i..j, from inside it.
  const auto beside = [&](int i, int j) { return j == i + 1 ? rim_normals[static_cast<std::size_t>(i)] : normal[at(i, j)]; };
  for (int length = 2; length < n; ++length)
    for (int i = 0; i + length < n; ++i) {
      const int j = i + length;
      if (!(i == 0 && j == n - 1) && !may_join(i, j)) continue;
      Weight& w = best[at(i, j)];
      for (int k = i + 1; k < j; ++k) {
        const Weight& left = best[at(i, k)];
        const Weight& right = best[at(k, j)];
        if (!left.feasible || !right.feasible) continue;
        // Wound (j, k, i): against the loop's sides i → k and k → j when they are sides.
        const Vec3 cross = (loop[static_cast<std::size_t>(k)] - loop[static_cast<std::size_t>(j)])
                               .cross(loop[static_cast<std::size_t>(i)] - loop[static_cast<std::size_t>(j)]);
        const double twice_area = cross.norm();
        if (!(twice_area > 0)) continue;
        const Vec3 n_t = cross / twice_area;
        const double diagonal = i == 0 && j == n - 1 ? 0.0 : (loop[static_cast<std::size_t>(j)] - loop[static_cast<std::size_t>(i)]).norm();
        Weight candidate{std::max({left.angle, right.angle, angle_between(n_t, beside(i, k)), angle_between(n_t, beside(k, j))}),
                         left.area + right.area + 0.5 * twice_area, std::max({left.longest, right.longest, diagonal}), true};
        if (i == 0 && j == n - 1)
          candidate.angle = std::max(candidate.angle, angle_between(n_t, rim_normals[static_cast<std::size_t>(n - 1)]));
        if (better(candidate, w)) {
          w = candidate;
          apex[at(i, j)] = k;
          normal[at(i, j)] = n_t;
        }
      }
    }
  const Weight& top = best[at(0, n - 1)];
  if (!top.feasible) return std::nullopt;
  LeastFoldingPatch patch;
  patch.max_dihedral_rad = top.angle;
  patch.area = top.area;
  std::vector<std::array<int, 2>> pending{{0, n - 1}};
  while (!pending.empty()) {
    const auto [i, j] = pending.back();
    pending.pop_back();
    if (j - i < 2) continue;
    const int k = apex[at(i, j)];
    patch.triangles.push_back({j, k, i});
    pending.push_back({i, k});
    pending.push_back({k, j});
  }
  return patch;
}

}  // namespace cmm::geometry
