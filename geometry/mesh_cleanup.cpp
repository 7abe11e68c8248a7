// Welding hashes points into a grid of cells and also looks into the neighbouring cells whenever the
// tolerance ball crosses a cell border, so near points on either side of it still merge.
#include "geometry/mesh_cleanup.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

namespace cmm::geometry {

namespace {

// Open addressing over ids (point or face numbers). The table keeps only each id and its hash; the caller
// owns the keys and tells which id it wants, so one table serves cells and faces, and one key may hold
// several ids (a cell, several points). Linear probing on the top hash bits.
class IdTable {
 public:
  struct Slot {
    std::uint32_t hash = 0;
    int id = -1;  // -1: empty
  };

  explicit IdTable(std::size_t expected) : slots_(std::bit_ceil(std::max<std::size_t>(16, 2 * expected))) {}

  // The first slot under `hash` whose id `wanted` accepts, else the empty slot where the probe ends. Room
  // for one more id is made first, so a slot found stays valid until the next fill().
  template <class Wanted>
  Slot& find(std::uint64_t hash, Wanted wanted) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    const std::uint32_t h = top(hash);
    for (std::size_t s = first_slot(h);; s = (s + 1) & (slots_.size() - 1)) {
      Slot& slot = slots_[s];
      if (slot.id < 0 || (slot.hash == h && wanted(slot.id))) return slot;
    }
  }

  // Starts loading the first slot under `hash` into the cache.
  void prefetch(std::uint64_t hash) const { __builtin_prefetch(&slots_[first_slot(top(hash))]); }

  // Puts an id into an empty slot that find() returned.
  void fill(Slot& slot, std::uint64_t hash, int id) {
    slot = {top(hash), id};
    ++size_;
  }

 private:
  static std::uint32_t top(std::uint64_t hash) { return static_cast<std::uint32_t>(hash >> 32); }
  std::size_t first_slot(std::uint32_t h) const { return h >> (32 - std::countr_zero(slots_.size())); }

  void grow() {
    std::vector<Slot> old(2 * slots_.size());
    old.swap(slots_);
    for (const Slot& slot : old) {
      if (slot.id < 0) continue;
      std::size_t s = first_slot(slot.hash);
      while (slots_[s].id >= 0) s = (s + 1) & (slots_.size() - 1);
      slots_[s] = slot;
    }
  }

  std::vector<Slot> slots_;
  std::size_t size_ = 0;
};

// Fibonacci hashing: spreads neighbouring keys over the top bits, which the table uses.
std::uint64_t spread(std::uint64_t key) { return key * 0x9E3779B97F4A7C15ULL; }

// Table lookups are cache misses, so the loops prefetch the slot they will need this many items ahead.
constexpr std::size_t prefetch_distance = 16;

double bbox_diagonal(const Points& points) {
  if (points.rows() == 0) return 0;
  return (points.colwise().maxCoeff() - points.colwise().minCoeff()).norm();
}

}  // namespace

Points weld_points(std::size_t count, const std::function<Vec3(std::size_t)>& point, const Vec3& low, const Vec3& high,
                   int* index_of) {
  const double tolerance = relative_tolerance * (high - low).norm();
  // Cells are 64 tolerances wide: few tolerance balls cross a border, and the bbox spans at most
  // 15,625 cells per axis, so 21 bits each pack a cell into one key. The +1 keeps the cell below the
  // bbox (reached by -tolerance) at 0.
  const double per_cell = tolerance > 0 ? 1 / (64 * tolerance) : 0;
  const auto cell = [&](double coordinate, int axis) {
    return static_cast<std::uint64_t>(std::floor((coordinate - low[axis]) * per_cell) + 1);
  };
  const auto cell_hash = [](std::uint64_t x, std::uint64_t y, std::uint64_t z) {
    return spread(x << 42 | y << 21 | z);
  };
  const auto own_cell = [&](const Vec3& p) { return cell_hash(cell(p.x(), 0), cell(p.y(), 1), cell(p.z(), 2)); };

  // Sized for the worst case, every point kept: pages never written cost nothing, and the final shrink
  // hands them back without a copy. (Page faults, not arithmetic, bound this function on large files.)
  Points kept(static_cast<Eigen::Index>(count), 3);
  int kept_count = 0;
  // A closed triangle mesh has about half as many vertices as faces: count / 6 of STL's corners.
  IdTable kept_in_cell(count / 6);

  // Most corners repeat a point met a few facets earlier. A small direct-mapped cache of recent points,
  // keyed on their exact coordinates, answers those without a trip into the cell table.
  struct Recent {
    Vec3 point;
    int index = -1;
  };
  std::vector<Recent> recent(4096);
  const auto recent_for = [&](const Vec3& p) -> Recent& {
    std::uint64_t bits = 0;
    for (const double c : p) bits = spread(bits ^ std::bit_cast<std::uint64_t>(c));
    return recent[bits >> 52];
  };

  for (std::size_t i = 0; i < count; ++i) {
    if (i + prefetch_distance < count) {
      const Vec3 ahead = point(i + prefetch_distance);
      const Recent& answer = recent_for(ahead);
      if (answer.index < 0 || answer.point != ahead) kept_in_cell.prefetch(own_cell(ahead));
    }
    const Vec3 p = point(i);
    Recent& seen = recent_for(p);
    if (seen.index >= 0 && seen.point == p) {
      index_of[i] = seen.index;
      continue;
    }
    // Any kept point within the tolerance will do, whichever cell it sits in.
    const auto near = [&](int v) { return (kept.row(v).transpose() - p).squaredNorm() <= tolerance * tolerance; };
    const std::uint64_t own = own_cell(p);
    IdTable::Slot& own_slot = kept_in_cell.find(own, near);
    int match = own_slot.id;
    for (auto x = cell(p.x() - tolerance, 0); match < 0 && x <= cell(p.x() + tolerance, 0); ++x) {
      for (auto y = cell(p.y() - tolerance, 1); match < 0 && y <= cell(p.y() + tolerance, 1); ++y) {
        for (auto z = cell(p.z() - tolerance, 2); match < 0 && z <= cell(p.z() + tolerance, 2); ++z) {
          if (cell_hash(x, y, z) != own) match = kept_in_cell.find(cell_hash(x, y, z), near).id;
        }
      }
    }
    if (match < 0) {
      match = kept_count++;
      kept.row(match) = p.transpose();
      kept_in_cell.fill(own_slot, own, match);
    }
    index_of[i] = match;
    seen = {p, match};
  }
  kept.conservativeResize(kept_count, 3);
  return kept;
}

void weld_vertices(TriangleMesh& mesh, ReadReport& report) {
  const auto n = static_cast<std::size_t>(mesh.vertices.rows());
  if (n == 0) return;
  std::vector<int> index_of(n);
  Points kept = weld_points(
      n, [&](std::size_t i) -> Vec3 { return mesh.vertices.row(static_cast<Eigen::Index>(i)).transpose(); },
      mesh.vertices.colwise().minCoeff().transpose(), mesh.vertices.colwise().maxCoeff().transpose(), index_of.data());
  if (mesh.vertex_normals.rows() == mesh.vertices.rows()) {
    // Kept points are numbered in order of first appearance, so point i is kept exactly when its index
    // is the next one; its normal moves forward in place.
    Eigen::Index next = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (index_of[i] == next) mesh.vertex_normals.row(next++) = mesh.vertex_normals.row(static_cast<Eigen::Index>(i));
    }
    mesh.vertex_normals.conservativeResize(kept.rows(), 3);
  }
  int* const corners = mesh.faces.data();
  for (Eigen::Index c = 0; c < mesh.faces.size(); ++c) corners[c] = index_of[static_cast<std::size_t>(corners[c])];
  report.vertices_welded += n - static_cast<std::size_t>(kept.rows());
  mesh.vertices = std::move(kept);
}

void drop_bad_faces(TriangleMesh& mesh, ReadReport& report) {
  Triangles& faces = mesh.faces;
  const double min_double_area = std::pow(relative_tolerance * bbox_diagonal(mesh.vertices), 2);
  const auto sorted = [&](Eigen::Index f) {
    std::array<int, 3> corners{faces(f, 0), faces(f, 1), faces(f, 2)};
    std::sort(corners.begin(), corners.end());
    return corners;
  };
  const auto hash = [](const std::array<int, 3>& corners) {
    std::uint64_t h = 0;
    for (const int c : corners) h = spread(h ^ static_cast<std::uint32_t>(c));
    return h;
  };

  IdTable seen(static_cast<std::size_t>(faces.rows()));
  Eigen::Index kept = 0;
  const auto ahead = static_cast<Eigen::Index>(prefetch_distance);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    if (f + ahead < faces.rows()) seen.prefetch(hash(sorted(f + ahead)));  // rows from f on are unmoved
    const std::array<int, 3> corners = sorted(f);
    const Vec3 a = vertex(mesh, corners[0]);
    const double double_area = (vertex(mesh, corners[1]) - a).cross(vertex(mesh, corners[2]) - a).norm();
    if (corners[0] == corners[1] || corners[1] == corners[2] || double_area <= min_double_area) {
      ++report.degenerate_faces_dropped;
      continue;
    }
    IdTable::Slot& slot = seen.find(hash(corners), [&](int g) { return sorted(g) == corners; });
    if (slot.id >= 0) {
      ++report.duplicate_faces_dropped;
      continue;
    }
    faces.row(kept) = faces.row(f);
    seen.fill(slot, hash(corners), static_cast<int>(kept++));
  }
  faces.conservativeResize(kept, 3);
}

}  // namespace cmm::geometry
