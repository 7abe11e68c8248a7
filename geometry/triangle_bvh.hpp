// Axis-aligned bounding-box tree over the faces of a triangle mesh, built once in linear-BVH fashion.
// It knows boxes only; the queries that walk it (ball sweeps, closest points) bring their own tests.
#pragma once

#include <array>
#include <span>
#include <utility>
#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

class TriangleBvh {
 public:
  struct Node {
    // Box of every corner of every face below, rounded outwards to floats: half the memory to walk.
    Eigen::Vector3f lo, hi;
    int first = 0;   // leaf: its first slot in order(); inner node: index of the first of its two children
    int count = 0;   // faces in a leaf; 0 marks an inner node
  };

  static constexpr int kLeafFaces = 4;
  // The deepest a leaf can be (63 Morton bits, then halving up to 2³¹ equal codes); bounds the walk's stack.
  static constexpr int kMaxDepth = 95;

  // Reads the mesh only here and keeps no reference to it. Coordinates must be finite.
  explicit TriangleBvh(const TriangleMesh& mesh);

  bool empty() const { return nodes_.empty(); }
  const std::vector<Node>& nodes() const { return nodes_; }
  // The face in each slot; a leaf's faces fill consecutive slots.
  const std::vector<int>& order() const { return order_; }
  std::span<const int> leaf_faces(const Node& leaf) const {
    return std::span<const int>(order_).subspan(leaf.first, leaf.count);
  }

  // The mesh with its faces in slot order and its vertices in order of first use, so that a walk reads
  // memory close to what it read last: at a million faces that saves many cache misses per query.
  TriangleMesh in_slot_order(const TriangleMesh& mesh) const;

  // Walks the tree nearest-first without recursion or allocation. `bound(lo, hi, limit)` is a lower bound
  // on what any face in the box can score (+∞ to prune); subtrees whose bound is not below `limit` are
  // skipped, and `leaf(first, count, limit)` scores the faces in a leaf's slots and returns the new,
  // never larger, limit.
  template <class Bound, class Leaf>
  void nearest_first(double limit, Bound&& bound, Leaf&& leaf) const;

 private:
  std::vector<Node> nodes_;  // root first; children always after their parent
  std::vector<int> order_;
};

template <class Bound, class Leaf>
void TriangleBvh::nearest_first(double limit, Bound&& bound, Leaf&& leaf) const {
  if (nodes_.empty()) return;
  // Each inner node popped pushes at most two children, so the stack never holds more than depth + 1.
  std::array<std::pair<int, double>, kMaxDepth + 2> stack;
  int top = 0;
  auto node_bound = [&](int index, double limit) {
    return bound(nodes_[index].lo.template cast<double>(), nodes_[index].hi.template cast<double>(), limit);
  };
  stack[top++] = {0, node_bound(0, limit)};
  while (top > 0) {
    const auto [index, key] = stack[--top];
    if (!(key < limit)) continue;
    const Node& node = nodes_[index];
    if (node.count > 0) {
      limit = leaf(node.first, node.count, limit);
      continue;
    }
    int near = node.first, far = node.first + 1;
    double near_key = node_bound(near, limit), far_key = node_bound(far, limit);
    if (far_key < near_key) {
      std::swap(near, far);
      std::swap(near_key, far_key);
    }
    if (far_key < limit) stack[top++] = {far, far_key};
    if (near_key < limit) stack[top++] = {near, near_key};
  }
}

}  // namespace cmm::geometry
