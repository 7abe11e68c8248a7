// One point per bin, by hashing each point's integer bin coordinates: linear time, and a bin index
// that cannot overflow on any cloud (three 64-bit integers, not one packed index).
#include "geometry/voxel_thinning.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "geometry/bin_size.hpp"

namespace cmm::geometry {

namespace {

// Bin coordinates past this would lose the integer precision of the double they come from (2⁵³
// bins along an axis is already 1 nm bins over 9,000 km) — refused, never wrapped.
constexpr double max_bins_per_axis = 4.6e18;  // < 2⁶²
constexpr int points_between_polls = 1 << 16;

struct Key {
  std::array<std::int64_t, 3> cell;
  int level = 0;
  bool operator==(const Key&) const = default;
};

struct KeyHash {
  std::size_t operator()(const Key& k) const {
    // splitmix64's finaliser over the combined words: bins of a surface are far from random, and the
    // standard library's identity hash of integers would pile them into few buckets.
    std::uint64_t h = static_cast<std::uint64_t>(k.level);
    for (std::int64_t c : k.cell) {
      h ^= static_cast<std::uint64_t>(c) + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
      h = (h ^ (h >> 30)) * 0xbf58476d1ce4e5b9ULL;
      h = (h ^ (h >> 27)) * 0x94d049bb133111ebULL;
      h ^= h >> 31;
    }
    return static_cast<std::size_t>(h);
  }
};

struct Best {
  int id = -1;
  double squared = 0;
};

// The cloud's grid: bins of `bin` aligned to the bounding-box minimum.
struct Grid {
  Vec3 min = Vec3::Zero();
  double bin = 1;

  std::array<std::int64_t, 3> cell(const Vec3& p) const {
    std::array<std::int64_t, 3> c{};
    for (int k = 0; k < 3; ++k) c[static_cast<std::size_t>(k)] = static_cast<std::int64_t>(std::floor((p(k) - min(k)) / bin));
    return c;
  }
  // Squared distance from p to the centre of the bin `cell` of `level` (side bin·2^level).
  double squared_to_centre(const Vec3& p, const std::array<std::int64_t, 3>& c, int level) const {
    const double side = std::ldexp(bin, level);
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const double d = (p(k) - min(k)) - (static_cast<double>(c[static_cast<std::size_t>(k)]) + 0.5) * side;
      d2 += d * d;
    }
    return d2;
  }
};

std::string describe(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

Grid make_grid(const Points& points, double bin_mm, const char* who) {
  if (!(bin_mm > 0) || !std::isfinite(bin_mm))
    throw std::invalid_argument(std::string(who) + ": the bin must be a positive number of mm, not " + describe(bin_mm));
  Grid grid;
  grid.bin = bin_mm;
  if (points.rows() == 0) return grid;
  if (!points.allFinite()) throw std::invalid_argument(std::string(who) + ": the cloud has a coordinate that is not a finite number");
  grid.min = points.colwise().minCoeff().transpose();
  const Vec3 extent = points.colwise().maxCoeff().transpose() - grid.min;
  const double bins = extent.maxCoeff() / bin_mm;
  if (!(bins < max_bins_per_axis))
    throw std::invalid_argument(std::string(who) + ": a bin of " + describe(bin_mm) + " mm cuts the cloud's " +
                                describe(extent.maxCoeff()) + " mm into more bins along an axis than can be counted");
  return grid;
}

void keep_nearer(std::unordered_map<Key, Best, KeyHash>& bins, const Key& key, int id, double squared) {
  auto [it, inserted] = bins.try_emplace(key, Best{id, squared});
  if (!inserted && squared < it->second.squared) it->second = Best{id, squared};  // ties: the lower index, met first
}

std::vector<int> kept(const std::unordered_map<Key, Best, KeyHash>& bins) {
  std::vector<int> ids;
  ids.reserve(bins.size());
  for (const auto& [key, best] : bins) ids.push_back(best.id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

}  // namespace

std::vector<int> thin_uniform(const Points& points, double bin_mm, const CancelCheck& cancel) {
  const Grid grid = make_grid(points, bin_mm, "voxel thinning");
  std::unordered_map<Key, Best, KeyHash> bins;
  bins.reserve(static_cast<std::size_t>(points.rows()));
  for (int i = 0; i < static_cast<int>(points.rows()); ++i) {
    if (i % points_between_polls == 0) cancel.throw_if_requested("voxel thinning");
    const Vec3 p = points.row(i).transpose();
    const Key key{grid.cell(p), 0};
    keep_nearer(bins, key, i, grid.squared_to_centre(p, key.cell, 0));
  }
  return kept(bins);
}

AdaptiveThinning thin_adaptive(const Points& points, const std::vector<LocalSurface>& fits,
                               const AdaptiveThinningOptions& options) {
  const Grid grid = make_grid(points, options.bin_mm, "adaptive voxel thinning");
  if (fits.size() != static_cast<std::size_t>(points.rows()))
    throw std::invalid_argument("adaptive voxel thinning: " + std::to_string(fits.size()) + " fits for " +
                                std::to_string(points.rows()) + " points");
  const int top = std::clamp(options.max_level, 0, 16);
  const int n = static_cast<int>(points.rows());

  // Each point's level: the coarsest B·2^l within the bin its own curvature allows at ε.
  std::vector<int> level(static_cast<std::size_t>(n), 0);
  std::vector<std::array<std::int64_t, 3>> cell(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const LocalSurface& f = fits[static_cast<std::size_t>(i)];
    cell[static_cast<std::size_t>(i)] = grid.cell(points.row(i).transpose());
    if (!f.regular) continue;
    const double allowed =
        bin_for_edge_length(edge_length_for_tolerance(options.tolerance_mm, std::abs(f.k1) + f.curvature_sigma, f.k2));
    const double ratio = allowed / options.bin_mm;
    level[static_cast<std::size_t>(i)] = ratio >= std::ldexp(1.0, top) ? top : std::max(0, static_cast<int>(std::floor(std::log2(ratio))));
  }
  auto at_level = [](std::array<std::int64_t, 3> c, int l) {
    for (auto& x : c) x >>= l;  // cells are ≥ 0 (aligned at the minimum): nested grids exactly
    return c;
  };

  // Per level ≥ 1, the least level asked for by the points of each bin.
  std::vector<std::unordered_map<Key, int, KeyHash>> least(static_cast<std::size_t>(top + 1));
  for (int l = 1; l <= top; ++l) {
    options.cancel.throw_if_requested("adaptive voxel thinning");
    auto& map = least[static_cast<std::size_t>(l)];
    for (int i = 0; i < n; ++i) {
      const Key key{at_level(cell[static_cast<std::size_t>(i)], l), l};
      auto [it, inserted] = map.try_emplace(key, level[static_cast<std::size_t>(i)]);
      if (!inserted) it->second = std::min(it->second, level[static_cast<std::size_t>(i)]);
    }
  }
  // A bin of level l serves when its points all allow l and its 26 neighbours' allow l − 1.
  std::vector<std::unordered_map<Key, bool, KeyHash>> serves(static_cast<std::size_t>(top + 1));
  auto bin_serves = [&](const Key& key) {
    auto& memo = serves[static_cast<std::size_t>(key.level)];
    if (const auto it = memo.find(key); it != memo.end()) return it->second;
    const auto& map = least[static_cast<std::size_t>(key.level)];
    bool ok = map.at(key) >= key.level;
    for (int dx = -1; dx <= 1 && ok; ++dx)
      for (int dy = -1; dy <= 1 && ok; ++dy)
        for (int dz = -1; dz <= 1 && ok; ++dz) {
          const Key next{{key.cell[0] + dx, key.cell[1] + dy, key.cell[2] + dz}, key.level};
          if (const auto it = map.find(next); it != map.end() && it->second < key.level - 1) ok = false;
        }
    memo.emplace(key, ok);
    return ok;
  };

  std::unordered_map<Key, Best, KeyHash> bins;
  for (int i = 0; i < n; ++i) {
    if (i % points_between_polls == 0) options.cancel.throw_if_requested("adaptive voxel thinning");
    Key key{cell[static_cast<std::size_t>(i)], 0};
    for (int l = top; l >= 1; --l) {
      const Key coarse{at_level(cell[static_cast<std::size_t>(i)], l), l};
      if (bin_serves(coarse)) {
        key = coarse;
        break;
      }
    }
    keep_nearer(bins, key, i, grid.squared_to_centre(points.row(i).transpose(), key.cell, key.level));
  }
  std::vector<std::pair<int, int>> by_id;  // (id, level)
  by_id.reserve(bins.size());
  for (const auto& [key, best] : bins) by_id.emplace_back(best.id, key.level);
  std::sort(by_id.begin(), by_id.end());
  AdaptiveThinning out;
  for (const auto& [id, l] : by_id) out.kept.push_back(id), out.levels.push_back(l);
  return out;
}

}  // namespace cmm::geometry
