// The grid sampler rasterises each face's projection instead of tracing every beam: a beam through a
// lattice point inside the projection of a face the view faces lands on that face unless something
// nearer the scanner hides the point, which is what visibility.occluded answers. The Poisson sampler
// thins dense candidates through a hash grid of cells one radius wide, built once over all of them.
#include "sim/scan_sampling.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <utility>

#include "sim/seed_streams.hpp"

namespace cmm::sim {

namespace {

using geometry::Vec3;
using Point2 = Eigen::Vector2d;

double cross(const Point2& u, const Point2& v) { return u.x() * v.y() - u.y() * v.x(); }

// Whether a lattice point on the edge from → to of a counter-clockwise triangle belongs to it: the
// top-left rule (top edges run horizontally leftward, left edges downward), so that of two faces
// sharing an edge, which run it in opposite directions, exactly one takes the point.
bool owns_edge(const Point2& from, const Point2& to) {
  return to.y() < from.y() || (to.y() == from.y() && to.x() < from.x());
}

bool inside(double weight, const Point2& from, const Point2& to) { return weight > 0 || (weight == 0 && owns_edge(from, to)); }

Vec3 corner(const geometry::TriangleMesh& scene, int face, int k) { return geometry::vertex(scene, scene.faces(face, k)); }

// The candidates bucketed by cells one Poisson radius wide, fixed once they are all drawn: sorted by
// cell, so each cell's candidates (and their points, copied) lie together, and found by an open
// addressing table from a cell's key to its range of slots. Far fewer cache misses than a map of
// vectors filled as points are kept, in a loop whose random order defeats every cache.
class CandidateCells {
 public:
  template <class CellKey>
  CandidateCells(const std::vector<SurfaceSample>& candidates, CellKey cell_key) : slot_of_(candidates.size()) {
    const std::size_t n = candidates.size();
    std::vector<std::uint64_t> keys(n);
    for (std::size_t i = 0; i < n; ++i) keys[i] = cell_key(candidates[i].point);
    std::vector<int> by_cell(n);
    std::iota(by_cell.begin(), by_cell.end(), 0);
    std::sort(by_cell.begin(), by_cell.end(), [&](int a, int b) { return keys[a] != keys[b] ? keys[a] < keys[b] : a < b; });
    points_.reserve(n);
    std::size_t cells = 0;
    for (std::size_t slot = 0; slot < n; ++slot) {
      slot_of_[by_cell[slot]] = static_cast<int>(slot);
      points_.push_back(candidates[by_cell[slot]].point);
      cells += slot == 0 || keys[by_cell[slot]] != keys[by_cell[slot - 1]];
    }
    std::size_t size = 16;
    while (size < 2 * cells) size *= 2;
    table_.assign(size, Entry{});
    mask_ = size - 1;
    for (std::size_t slot = 0; slot < n; ++slot) {
      const std::uint64_t k = keys[by_cell[slot]];
      std::size_t at = mix(k) & mask_;
      while (table_[at].key != kEmpty && table_[at].key != k) at = (at + 1) & mask_;
      if (table_[at].key == kEmpty) table_[at] = {k, static_cast<int>(slot), static_cast<int>(slot)};
      table_[at].end = static_cast<int>(slot) + 1;
    }
  }
  // The slots [begin, end) of the cell's candidates; empty for a cell without any.
  std::pair<int, int> slots(std::uint64_t key) const {
    for (std::size_t at = mix(key) & mask_;; at = (at + 1) & mask_) {
      if (table_[at].key == key) return {table_[at].begin, table_[at].end};
      if (table_[at].key == kEmpty) return {0, 0};
    }
  }
  int slot_of(int candidate) const { return slot_of_[candidate]; }
  const Vec3& point(int slot) const { return points_[slot]; }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // no cell key: the key's top bit is never set
  struct Entry {
    std::uint64_t key = kEmpty;
    int begin = 0, end = 0;
  };
  // splitmix64's finaliser: neighbouring cells' keys differ in few bits, the table's index needs them all.
  static std::uint64_t mix(std::uint64_t x) {
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
  }
  std::vector<int> slot_of_;
  std::vector<Vec3> points_;
  std::vector<Entry> table_;
  std::size_t mask_ = 0;
};

}  // namespace

Vec3 sample_triangle(std::mt19937_64& engine, const Vec3& a, const Vec3& b, const Vec3& c) {
  std::uniform_real_distribution<double> unit(0, 1);
  const double r = std::sqrt(unit(engine)), s = unit(engine);
  return (1 - r) * a + r * (1 - s) * b + r * s * c;
}

std::vector<SurfaceSample> grid_samples(const SamplerInput& in) {
  const geometry::TriangleMesh& scene = in.visibility.scene();
  std::mt19937_64 engine = seed_stream(in.seed, SeedStream::grid_offsets);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<SurfaceSample> samples;
  for (int v = 0; v < static_cast<int>(in.views.size()); ++v) {
    const Vec3& direction = in.views[v].direction;
    const double pitch = in.spacing_mm / std::sqrt(in.density[v]);
    const auto [across, up] = image_axes(direction);
    const double offset_across = unit(engine) * pitch, offset_up = unit(engine) * pitch;
    const auto image = [&](const Vec3& p) { return Point2(across.dot(p), up.dot(p)); };
    for (int f = 0; f < scene.faces.rows(); ++f) {
      if (!in.visibility.facing(f, direction)) continue;
      Vec3 a = corner(scene, f, 0), b = corner(scene, f, 1), c = corner(scene, f, 2);
      Point2 a2 = image(a), b2 = image(b), c2 = image(c);
      double twice_area = cross(b2 - a2, c2 - a2);
      if (twice_area < 0) {  // every faced face projects the same way round; make it counter-clockwise
        std::swap(b, c);
        std::swap(b2, c2);
        twice_area = -twice_area;
      }
      if (!(twice_area > 0)) continue;
      const Point2 lo = a2.cwiseMin(b2).cwiseMin(c2), hi = a2.cwiseMax(b2).cwiseMax(c2);
      const auto first = [&](double low, double offset) { return static_cast<long long>(std::ceil((low - offset) / pitch)); };
      const auto last = [&](double high, double offset) { return static_cast<long long>(std::floor((high - offset) / pitch)); };
      for (long long i = first(lo.x(), offset_across); i <= last(hi.x(), offset_across); ++i)
        for (long long j = first(lo.y(), offset_up); j <= last(hi.y(), offset_up); ++j) {
          const Point2 q(offset_across + static_cast<double>(i) * pitch, offset_up + static_cast<double>(j) * pitch);
          // Each weight is twice the area of the sub-triangle opposite its corner: barycentric × 2 area.
          const double wa = cross(c2 - b2, q - b2), wb = cross(a2 - c2, q - c2), wc = cross(b2 - a2, q - a2);
          if (!inside(wa, b2, c2) || !inside(wb, c2, a2) || !inside(wc, a2, b2)) continue;
          // A parallel projection keeps barycentric coordinates: the beam meets the face here.
          const Vec3 p = (wa * a + wb * b + wc * c) / (wa + wb + wc);
          if (!in.coverage[v].keeps(p) || in.visibility.occluded(p, f, direction)) continue;
          samples.push_back({p, f, v});
        }
    }
  }
  return samples;
}

std::vector<SurfaceSample> poisson_samples(const SamplerInput& in) {
  const geometry::TriangleMesh& scene = in.visibility.scene();
  const geometry::FaceGeometry& faces = in.visibility.face_geometry();
  std::vector<SurfaceSample> candidates;
  if (scene.faces.rows() == 0) return candidates;
  std::mt19937_64 engine = seed_stream(in.seed, SeedStream::poisson);
  std::uniform_real_distribution<double> unit(0, 1);
  const double per_area = kPoissonCandidates / (in.spacing_mm * in.spacing_mm);

  // Candidates over the union: each face once, whichever views face it, so the union's candidate density
  // does not grow where views overlap.
  std::vector<std::pair<double, int>> turn;  // (exponential clock, view): the first to ring that sees it
  for (int f = 0; f < scene.faces.rows(); ++f) {
    std::vector<int> facing;
    for (int v = 0; v < static_cast<int>(in.views.size()); ++v)
      if (in.visibility.facing(f, in.views[v].direction)) facing.push_back(v);
    if (facing.empty()) continue;
    const double expected = faces.areas[f] * per_area;
    const int count = static_cast<int>(expected) + (unit(engine) < expected - std::floor(expected) ? 1 : 0);
    const Vec3 a = corner(scene, f, 0), b = corner(scene, f, 1), c = corner(scene, f, 2);
    for (int k = 0; k < count; ++k) {
      const Vec3 p = sample_triangle(engine, a, b, c);
      // Exponential clocks of rate density: the order they ring in is a random order in which each view
      // comes first with odds in proportion to its density, so the first that sees p is such a draw
      // among the views that see it.
      turn.clear();
      for (int v : facing) turn.emplace_back(-std::log1p(-unit(engine)) / in.density[v], v);
      std::sort(turn.begin(), turn.end());
      for (const auto& [clock, v] : turn)
        if (in.coverage[v].keeps(p) && !in.visibility.occluded(p, f, in.views[v].direction)) {
          candidates.push_back({p, f, v});
          break;
        }
    }
  }

  const double radius = kPoissonRadius * in.spacing_mm;
  const Vec3 origin = scene.vertices.colwise().minCoeff().transpose();
  const Vec3 extent = scene.vertices.colwise().maxCoeff().transpose() - origin;
  constexpr double kCellsPerAxis = 1 << 20;  // 21 bits of the key per axis, one to spare for the neighbours
  if (!(extent.maxCoeff() / radius < kCellsPerAxis - 2))
    throw std::invalid_argument("raw scan: spacing_mm too small for poisson sampling of a part this large");
  const auto cell = [&](const Vec3& p) -> Eigen::Array3i {
    return ((p - origin) / radius).array().floor().cast<int>() + 1;  // ≥ 0 for the neighbours below
  };
  const auto key = [](const Eigen::Array3i& c) {
    return (static_cast<std::uint64_t>(c.x()) << 42) | (static_cast<std::uint64_t>(c.y()) << 21) |
           static_cast<std::uint64_t>(c.z());
  };
  const CandidateCells cells(candidates, [&](const Vec3& p) { return key(cell(p)); });

  std::vector<int> order(candidates.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), engine);
  std::vector<char> kept_at(candidates.size(), 0);  // by slot
  std::vector<int> kept;
  const double squared_radius = radius * radius;
  for (int i : order) {
    const Vec3& p = candidates[i].point;
    const Eigen::Array3i home = cell(p);
    bool crowded = false;
    for (int dx = -1; dx <= 1 && !crowded; ++dx)
      for (int dy = -1; dy <= 1 && !crowded; ++dy)
        for (int dz = -1; dz <= 1 && !crowded; ++dz) {
          const auto [begin, end] = cells.slots(key(home + Eigen::Array3i(dx, dy, dz)));
          for (int slot = begin; slot < end && !crowded; ++slot)
            crowded = kept_at[slot] && (cells.point(slot) - p).squaredNorm() < squared_radius;
        }
    if (crowded) continue;
    kept_at[cells.slot_of(i)] = 1;
    kept.push_back(i);
  }
  // Candidates were made in face order; grouped by view they read like the other samplers' scans.
  std::sort(kept.begin(), kept.end(), [&](int x, int y) {
    return candidates[x].view != candidates[y].view ? candidates[x].view < candidates[y].view : x < y;
  });
  std::vector<SurfaceSample> samples;
  samples.reserve(kept.size());
  for (int i : kept) samples.push_back(candidates[i]);
  return samples;
}

}  // namespace cmm::sim
