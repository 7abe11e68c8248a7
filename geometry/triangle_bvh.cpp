// Built as a linear BVH: faces sorted once along a Morton curve, each range split where its codes first
// differ (an octree-like split that needs no pass over the faces), boxes filled bottom-up.
#include "geometry/triangle_bvh.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

namespace cmm::geometry {

namespace {

struct Keyed {
  std::uint64_t code;
  int face;
};

// Spreads the low 21 bits of v apart so that two zero bits follow each (the usual Morton bit trick).
std::uint64_t spread(std::uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffff;
  v = (v | v << 16) & 0x1f0000ff0000ff;
  v = (v | v << 8) & 0x100f00f00f00f00f;
  v = (v | v << 4) & 0x10c30c30c30c30c3;
  v = (v | v << 2) & 0x1249249249249249;
  return v;
}

const double* corner(const TriangleMesh& mesh, int f, int c) { return &mesh.vertices(mesh.faces(f, c), 0); }

// Faces sorted along a Morton curve through the box of their centroids, quantized to 2²¹ steps along
// its longest side. Plain arrays rather than Eigen keep this quick in Debug builds too.
std::vector<Keyed> morton_order(const TriangleMesh& mesh) {
  const int faces = static_cast<int>(mesh.faces.rows());
  auto centroid = [&](int f) {  // three times over: only the order matters
    const double *a = corner(mesh, f, 0), *b = corner(mesh, f, 1), *c = corner(mesh, f, 2);
    return std::array<double, 3>{a[0] + b[0] + c[0], a[1] + b[1] + c[1], a[2] + b[2] + c[2]};
  };
  std::array<double, 3> lo = centroid(0), hi = lo;
  for (int f = 1; f < faces; ++f) {
    const std::array<double, 3> x = centroid(f);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], x[k]);
      hi[k] = std::max(hi[k], x[k]);
    }
  }
  const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  const double steps = extent > 0 ? ((1 << 21) - 1) / extent : 0;
  std::vector<Keyed> keyed(faces);
  for (int f = 0; f < faces; ++f) {
    const std::array<double, 3> x = centroid(f);
    std::uint64_t code = 0;
    for (int k = 0; k < 3; ++k) code |= spread(static_cast<std::uint64_t>((x[k] - lo[k]) * steps)) << (2 - k);
    keyed[f] = {code, f};
  }
  std::sort(keyed.begin(), keyed.end(), [](const Keyed& a, const Keyed& b) {
    return a.code != b.code ? a.code < b.code : a.face < b.face;
  });
  return keyed;
}

float round_down(double x) {
  const float f = static_cast<float>(x);
  return f > x ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}

float round_up(double x) {
  const float f = static_cast<float>(x);
  return f < x ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

struct Task {
  int node, begin, end;
};

}  // namespace

TriangleBvh::TriangleBvh(const TriangleMesh& mesh) {
  const int faces = static_cast<int>(mesh.faces.rows());
  if (faces == 0) return;
  const std::vector<Keyed> keyed = morton_order(mesh);
  order_.resize(faces);
  std::transform(keyed.begin(), keyed.end(), order_.begin(), [](const Keyed& k) { return k.face; });

  // Each split falls at the highest bit where the range's codes differ, which both halves then share,
  // so bit splits nest at most 63 deep; equal codes are halved, at most 31 more levels (kMaxDepth).
  nodes_.reserve(faces);
  nodes_.emplace_back();
  std::vector<Task> tasks{{0, 0, faces}};
  while (!tasks.empty()) {
    const Task task = tasks.back();
    tasks.pop_back();
    if (task.end - task.begin <= kLeafFaces) {
      nodes_[task.node].first = task.begin;
      nodes_[task.node].count = task.end - task.begin;
      continue;
    }
    const std::uint64_t first = keyed[task.begin].code, last = keyed[task.end - 1].code;
    int middle = task.begin + (task.end - task.begin) / 2;
    if (first != last) {
      const std::uint64_t bit = std::uint64_t{1} << (63 - std::countl_zero(first ^ last));
      middle = static_cast<int>(std::partition_point(keyed.begin() + task.begin, keyed.begin() + task.end,
                                                     [bit](const Keyed& k) { return (k.code & bit) == 0; }) -
                                keyed.begin());
    }
    const int children = static_cast<int>(nodes_.size());
    nodes_[task.node].first = children;
    nodes_.emplace_back();
    nodes_.emplace_back();
    tasks.push_back({children + 1, middle, task.end});
    tasks.push_back({children, task.begin, middle});
  }

  // Children come after their parent, so one backward pass sees every child before its parent.
  for (auto node = nodes_.rbegin(); node != nodes_.rend(); ++node) {
    if (node->count == 0) {
      const Node& a = nodes_[node->first];
      const Node& b = nodes_[node->first + 1];
      node->lo = a.lo.cwiseMin(b.lo);
      node->hi = a.hi.cwiseMax(b.hi);
      continue;
    }
    const double* start = corner(mesh, order_[node->first], 0);
    double lo[3] = {start[0], start[1], start[2]}, hi[3] = {start[0], start[1], start[2]};
    for (int slot = node->first; slot < node->first + node->count; ++slot)
      for (int c = 0; c < 3; ++c) {
        const double* p = corner(mesh, order_[slot], c);
        for (int k = 0; k < 3; ++k) {
          lo[k] = std::min(lo[k], p[k]);
          hi[k] = std::max(hi[k], p[k]);
        }
      }
    node->lo = {round_down(lo[0]), round_down(lo[1]), round_down(lo[2])};
    node->hi = {round_up(hi[0]), round_up(hi[1]), round_up(hi[2])};
  }
}

TriangleMesh TriangleBvh::in_slot_order(const TriangleMesh& mesh) const {
  TriangleMesh ordered{Points(mesh.vertices.rows(), 3), Triangles(mesh.faces.rows(), 3), Points(0, 3)};
  std::vector<int> renumbered(mesh.vertices.rows(), -1);
  int used = 0;
  for (int slot = 0; slot < static_cast<int>(order_.size()); ++slot)
    for (int c = 0; c < 3; ++c) {
      int& v = renumbered[mesh.faces(order_[slot], c)];
      if (v < 0) {
        v = used++;
        ordered.vertices.row(v) = mesh.vertices.row(mesh.faces(order_[slot], c));
      }
      ordered.faces(slot, c) = v;
    }
  ordered.vertices.conservativeResize(used, 3);  // vertices no face uses are of no use here
  return ordered;
}

}  // namespace cmm::geometry
