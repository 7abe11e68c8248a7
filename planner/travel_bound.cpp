// Exact minimum spanning trees for the travel bound: the Euclidean tree (minimal for the cost too, the
// cost growing with the distance) by Prim for small sets and by Borůvka for large ones, whose
// nearest-foreign-point queries run on a k-d tree that knows which subtrees lie inside one component
// and skips them.
#include "planner/travel_bound.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace cmm::planner {
namespace {

static_assert(sizeof(Eigen::Vector2d) == 2 * sizeof(double), "a vector of points is read as x, y, x, y, …");

constexpr std::size_t prim_limit = 5000;  // Prim's n² cost evaluations stay below ≈ 0.1 s
constexpr int leaf_size = 8;

void check_finite(const std::vector<Eigen::Vector2d>& points) {
  for (const Eigen::Vector2d& p : points)
    if (!p.allFinite()) throw std::invalid_argument("minimum spanning tree: point with a non-finite coordinate");
}

// A candidate edge, ordered by squared length and then by its end indices: a strict total order, so
// equal lengths (grids, duplicates) cannot make two components pick edges that close a cycle.
struct Edge {
  double length2 = std::numeric_limits<double>::infinity();
  int a = -1, b = -1;  // a < b
};

Edge make_edge(int i, int j, double length2) { return {length2, std::min(i, j), std::max(i, j)}; }

bool shorter(const Edge& x, const Edge& y) {
  if (x.length2 != y.length2) return x.length2 < y.length2;
  if (x.a != y.a) return x.a < y.a;
  return x.b < y.b;
}

// Computed one way only, so the same pair always gets bit-identical lengths. Plain arrays rather than
// Eigen in the inner loops: unoptimised (sanitizer) builds would otherwise spend seconds here.
double distance2(const double* p, const double* q) {
  const double dx = p[0] - q[0], dy = p[1] - q[1];
  return dx * dx + dy * dy;
}

struct KdNode {
  double low[2], high[2];     // bounding box of the node's points
  int begin = 0, end = 0;     // range in KdTree::ids
  int left = -1, right = -1;  // children; -1 for a leaf
};

// Children always follow their parent in nodes, so a reverse sweep sees children first.
struct KdTree {
  std::vector<int> ids;        // point ids in leaf order
  std::vector<double> sorted;  // their x, y, same order
  std::vector<KdNode> nodes;
};

int build_node(KdTree& tree, const double* xy, int begin, int end) {
  KdNode node;
  node.begin = begin;
  node.end = end;
  for (int axis = 0; axis < 2; ++axis) {
    node.low[axis] = node.high[axis] = xy[2 * tree.ids[begin] + axis];
    for (int k = begin + 1; k < end; ++k) {
      node.low[axis] = std::min(node.low[axis], xy[2 * tree.ids[k] + axis]);
      node.high[axis] = std::max(node.high[axis], xy[2 * tree.ids[k] + axis]);
    }
  }
  const int index = static_cast<int>(tree.nodes.size());
  tree.nodes.push_back(node);
  if (end - begin <= leaf_size) return index;
  const int axis = node.high[0] - node.low[0] >= node.high[1] - node.low[1] ? 0 : 1;
  const int middle = begin + (end - begin) / 2;
  std::nth_element(tree.ids.begin() + begin, tree.ids.begin() + middle, tree.ids.begin() + end,
                   [&](int i, int j) { return xy[2 * i + axis] < xy[2 * j + axis]; });
  const int left = build_node(tree, xy, begin, middle);
  const int right = build_node(tree, xy, middle, end);
  tree.nodes[index].left = left;
  tree.nodes[index].right = right;
  return index;
}

KdTree build_kd_tree(const double* xy, int n) {
  KdTree tree;
  tree.ids.resize(n);
  std::iota(tree.ids.begin(), tree.ids.end(), 0);
  build_node(tree, xy, 0, n);
  tree.sorted.reserve(2 * n);
  for (int id : tree.ids) tree.sorted.insert(tree.sorted.end(), {xy[2 * id], xy[2 * id + 1]});
  return tree;
}

double box_distance2(const KdNode& node, const double* q) {
  const double dx = q[0] < node.low[0] ? node.low[0] - q[0] : q[0] > node.high[0] ? q[0] - node.high[0] : 0.0;
  const double dy = q[1] < node.low[1] ? node.low[1] - q[1] : q[1] > node.high[1] ? q[1] - node.high[1] : 0.0;
  return dx * dx + dy * dy;
}

int find_root(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// One Borůvka round's view of the components: per point its component, per node the component all
// its points share (or -1), so a query can skip subtrees of its own component.
struct Components {
  std::vector<int> of_point;
  std::vector<int> of_node;
};

Components label_components(const KdTree& tree, std::vector<int>& parent) {
  Components c;
  c.of_point.resize(parent.size());
  for (int i = 0; i < static_cast<int>(parent.size()); ++i) c.of_point[i] = find_root(parent, i);
  c.of_node.assign(tree.nodes.size(), -1);
  for (int n = static_cast<int>(tree.nodes.size()) - 1; n >= 0; --n) {
    const KdNode& node = tree.nodes[n];
    if (node.left >= 0) {
      const int l = c.of_node[node.left], r = c.of_node[node.right];
      c.of_node[n] = l == r ? l : -1;
      continue;
    }
    const int first = c.of_point[tree.ids[node.begin]];
    bool uniform = true;
    for (int k = node.begin + 1; k < node.end && uniform; ++k) uniform = c.of_point[tree.ids[k]] == first;
    c.of_node[n] = uniform ? first : -1;
  }
  return c;
}

// Improves best with the shortest edge from point `query` to a point outside its component;
// node_distance2 is the squared distance from q to the node's box.
void nearest_foreign(const KdTree& tree, const Components& components, int node_index, double node_distance2,
                     int query, const double* q, Edge& best) {
  const int own = components.of_point[query];
  if (components.of_node[node_index] == own || node_distance2 > best.length2) return;
  const KdNode& node = tree.nodes[node_index];
  if (node.left < 0) {
    for (int k = node.begin; k < node.end; ++k) {
      const int j = tree.ids[k];
      if (components.of_point[j] == own) continue;
      const Edge edge = make_edge(query, j, distance2(q, &tree.sorted[2 * k]));
      if (shorter(edge, best)) best = edge;
    }
    return;
  }
  const double left = box_distance2(tree.nodes[node.left], q), right = box_distance2(tree.nodes[node.right], q);
  if (left <= right) {
    nearest_foreign(tree, components, node.left, left, query, q, best);
    nearest_foreign(tree, components, node.right, right, query, q, best);
  } else {
    nearest_foreign(tree, components, node.right, right, query, q, best);
    nearest_foreign(tree, components, node.left, left, query, q, best);
  }
}

}  // namespace

// Keys are squared distances, the same order as the cost, so the cost is evaluated once per tree
// edge rather than once per pair.
double prim_spanning_tree_cost(const std::vector<Eigen::Vector2d>& points, const TravelCost& cost) {
  check_finite(points);
  const std::size_t n = points.size();
  if (n < 2) return 0;
  std::vector<double> keys(n, std::numeric_limits<double>::infinity());
  std::vector<char> in_tree_flags(n, 0);
  double* key = keys.data();
  char* in_tree = in_tree_flags.data();
  const double* xy = points.front().data();
  double total = 0;
  std::size_t next = 0;
  key[0] = 0;
  for (std::size_t added = 0; added < n; ++added) {
    const std::size_t u = next;
    in_tree[u] = 1;
    total += cost.of_distance(std::sqrt(key[u]));
    double best = std::numeric_limits<double>::infinity();
    const double ux = xy[2 * u], uy = xy[2 * u + 1];
    for (std::size_t v = 0; v < n; ++v) {  // no calls in here: this loop is all of Prim's time
      if (in_tree[v]) continue;
      const double dx = ux - xy[2 * v], dy = uy - xy[2 * v + 1];
      const double length2 = dx * dx + dy * dy;
      if (length2 < key[v]) key[v] = length2;
      if (key[v] < best) {
        best = key[v];
        next = v;
      }
    }
  }
  return total;
}

double boruvka_spanning_tree_cost(const std::vector<Eigen::Vector2d>& points, const TravelCost& cost) {
  check_finite(points);
  const int n = static_cast<int>(points.size());
  if (n < 2) return 0;
  const KdTree tree = build_kd_tree(points.front().data(), n);
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  double total = 0;
  for (int components_left = n; components_left > 1;) {
    const Components components = label_components(tree, parent);
    std::vector<Edge> best(n);  // indexed by component root
    for (int k = 0; k < n; ++k) {  // leaf order: neighbouring queries share their search paths
      const int i = tree.ids[k];
      nearest_foreign(tree, components, 0, 0.0, i, &tree.sorted[2 * k], best[components.of_point[i]]);
    }
    for (int root = 0; root < n; ++root) {
      const Edge& edge = best[root];
      if (edge.a < 0) continue;
      const int ra = find_root(parent, edge.a), rb = find_root(parent, edge.b);
      if (ra == rb) continue;  // the component at the other end chose the same edge
      parent[ra] = rb;
      total += cost.of_distance(std::sqrt(edge.length2));
      --components_left;
    }
  }
  return total;
}

double minimum_spanning_tree_cost(const std::vector<Eigen::Vector2d>& points, const TravelCost& cost) {
  return points.size() <= prim_limit ? prim_spanning_tree_cost(points, cost)
                                     : boruvka_spanning_tree_cost(points, cost);
}

double travel_lower_bound(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& home,
                          const TravelCost& cost) {
  std::vector<Eigen::Vector2d> with_home;
  with_home.reserve(points.size() + 1);
  with_home.push_back(home);
  with_home.insert(with_home.end(), points.begin(), points.end());
  return minimum_spanning_tree_cost(with_home, cost);
}

}  // namespace cmm::planner
