// Touch ordering as a path with fixed ends: home at the start and, at the end, home again or a free
// end (a dummy point at zero cost from everything). The path is stored as a cycle closed by the
// locked edge end → start, in an array with a position index, so that 2-opt can reverse whichever
// side of the cycle is shorter and Or-opt moves decompose into 2-opt moves.
#include "planner/tour_order.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <numeric>
#include <stdexcept>

#include <nanoflann.hpp>

namespace cmm::planner {
namespace {

static_assert(sizeof(Eigen::Vector2d) == 2 * sizeof(double), "a vector of points is read as x, y, x, y, …");

using Clock = std::chrono::steady_clock;

// Gains below this (seconds) are rounding, not improvement; ignoring them keeps the search from
// cycling among equal-cost orders (ties and duplicates).
constexpr double min_gain_s = 1e-10;

// Exact duplicates collapse into one site: visiting them back to back costs nothing, so a good
// order of the distinct sites expands into an equally good order of all points, and the candidate
// lists are not filled up with copies of one point.
struct Sites {
  std::vector<Eigen::Vector2d> xy;
  std::vector<int> first;    // site i holds members[first[i] … first[i+1])
  std::vector<int> members;  // input indices, ascending within a site
};

Sites distinct_sites(const std::vector<Eigen::Vector2d>& points) {
  const int n = static_cast<int>(points.size());
  std::vector<int> by_position(n);
  std::iota(by_position.begin(), by_position.end(), 0);
  std::sort(by_position.begin(), by_position.end(), [&](int i, int j) {
    if (points[i].x() != points[j].x()) return points[i].x() < points[j].x();
    return points[i].y() < points[j].y();
  });
  std::vector<int> twin(n);  // the first index (in sort order) with the same coordinates
  for (int k = 0; k < n; ++k)
    twin[by_position[k]] = k > 0 && points[by_position[k]] == points[by_position[k - 1]] ? twin[by_position[k - 1]]
                                                                                       : by_position[k];
  // Sites numbered by first appearance in the input, members in input order.
  std::vector<int> site_of(n, -1), count;
  for (int i = 0; i < n; ++i) {
    int& site = site_of[twin[i]];
    if (site < 0) {
      site = static_cast<int>(count.size());
      count.push_back(0);
    }
    site_of[i] = site;
    ++count[site];
  }
  Sites sites;
  sites.first.assign(count.size() + 1, 0);
  for (std::size_t s = 0; s < count.size(); ++s) sites.first[s + 1] = sites.first[s] + count[s];
  sites.members.resize(n);
  sites.xy.resize(count.size());
  std::vector<int> fill(sites.first.begin(), sites.first.end() - 1);
  for (int i = 0; i < n; ++i) {
    sites.members[fill[site_of[i]]++] = i;
    sites.xy[site_of[i]] = points[i];
  }
  return sites;
}

// nanoflann dataset adaptor over a subset of the nodes.
struct NodeSubset {
  const std::vector<Eigen::Vector2d>* xy = nullptr;
  std::vector<int> ids;
  std::size_t kdtree_get_point_count() const { return ids.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t axis) const { return (*xy)[ids[i]][static_cast<int>(axis)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const { return false; }
};

using KdIndex =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, NodeSubset>, NodeSubset, 2, std::uint32_t>;

// For each node in `ids`, its k nearest other nodes, nearest first, in a flat array of stride
// `stride` (−1 where there are fewer); `front`, when ≥ 0, takes the first slot of every list.
std::vector<int> candidate_lists(const std::vector<Eigen::Vector2d>& xy, const std::vector<int>& ids, int k,
                                 int front, int stride) {
  std::vector<int> lists(xy.size() * stride, -1);
  NodeSubset data{&xy, ids};
  const KdIndex index(2, data, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  const std::size_t wanted = std::min<std::size_t>(k + 1, ids.size());  // +1: the node itself
  std::vector<std::uint32_t> found(wanted);
  std::vector<double> distance2(wanted);
  for (int node : ids) {
    nanoflann::KNNResultSet<double, std::uint32_t> result(wanted);
    result.init(found.data(), distance2.data());
    index.findNeighbors(result, xy[node].data(), nanoflann::SearchParams());
    int* list = &lists[static_cast<std::size_t>(node) * stride];
    int filled = 0;
    if (front >= 0) list[filled++] = front;
    for (std::size_t r = 0; r < result.size() && filled < stride; ++r)
      if (ids[found[r]] != node) list[filled++] = ids[found[r]];
  }
  return lists;
}

// nanoflann result set: the nearest site not yet visited.
struct NearestUnvisited {
  const std::vector<int>& ids;
  const std::vector<char>& visited;
  double best = std::numeric_limits<double>::infinity();
  int site = -1;
  bool full() const { return site >= 0; }
  double worstDist() const { return best; }
  bool addPoint(double distance2, std::uint32_t i) {
    const int id = ids[i];
    if (!visited[id] && (distance2 < best || (distance2 == best && id < site))) {
      best = distance2;
      site = id;
    }
    return true;
  }
};

// Nearest-neighbour path from home over the sites. The next site is usually among the current
// node's candidates; only when all of those are visited does it query a k-d tree of the unvisited
// sites that skips the ones visited since it was built. The tree is rebuilt whenever half of its
// sites are visited, so queries never wade through a mostly visited tree (O(n log n) in all).
std::vector<int> nearest_neighbour_path(const std::vector<Eigen::Vector2d>& xy, int sites, int start,
                                        const std::vector<int>& candidates, int stride) {
  std::vector<char> visited(sites, 0);
  NodeSubset unvisited{&xy, {}};
  std::unique_ptr<KdIndex> tree;  // built at the first query, on the sites still unvisited then
  std::vector<int> path;
  path.reserve(sites);
  for (int current = start; static_cast<int>(path.size()) < sites;) {
    int next = -1;
    for (int r = 0; r < stride && next < 0; ++r) {
      const int c = candidates[static_cast<std::size_t>(current) * stride + r];
      if (c >= 0 && c < sites && !visited[c]) next = c;
    }
    if (next < 0) {
      const std::size_t remaining = sites - path.size();
      if (!tree || 2 * remaining < unvisited.ids.size()) {
        unvisited.ids.clear();
        for (int site = 0; site < sites; ++site)
          if (!visited[site]) unvisited.ids.push_back(site);
        tree = std::make_unique<KdIndex>(2, unvisited, nanoflann::KDTreeSingleIndexAdaptorParams(10));
      }
      NearestUnvisited result{unvisited.ids, visited};
      tree->findNeighbors(result, xy[current].data(), nanoflann::SearchParams());
      next = result.site;
    }
    visited[next] = 1;
    path.push_back(next);
    current = next;
  }
  return path;
}

struct Move {
  double gain = min_gain_s;
  bool or_opt = false;
  // 2-opt: replace edges (a, b) and (c, d) by (a, c) and (b, d), b and d on the same side of a and c.
  // Or-opt: move the segment s1 … sL (between p and nx) between c and d, with c next to e.
  int a = -1, b = -1, c = -1, d = -1;
  int p = -1, s1 = -1, sl = -1, nx = -1, e = -1;
};

// 2-opt and Or-opt on the cycle start → sites → end → start, with the edge end–start locked.
class PathImprover {
 public:
  PathImprover(const std::vector<Eigen::Vector2d>& xy, const TravelCost& cost, bool open_end,
               const std::vector<int>& candidates, int stride, const std::vector<int>& path)
      : coordinates_(xy.front().data()), cost_(cost), open_end_(open_end), candidates_(candidates), stride_(stride) {
    start_ = static_cast<int>(path.size());
    end_ = start_ + 1;
    tour_.push_back(start_);
    tour_.insert(tour_.end(), path.begin(), path.end());
    tour_.push_back(end_);
    position_.resize(tour_.size());
    for (int k = 0; k < static_cast<int>(tour_.size()); ++k) position_[tour_[k]] = k;
  }

  // Don't-look bits as a queue: a node is examined again only when an edge at it changed.
  void improve(Clock::time_point deadline, long max_moves) {
    const int m = static_cast<int>(tour_.size());
    if (m < 4 || max_moves == 0) return;
    std::deque<int> queue(tour_.begin(), tour_.end());
    std::vector<char> queued(m, 1);
    long moves = 0, examined = 0;
    while (!queue.empty()) {
      if (examined++ % 64 == 0 && Clock::now() > deadline) return;
      const int v = queue.front();
      queue.pop_front();
      queued[v] = 0;
      const Move move = best_move(v);
      if (move.gain <= min_gain_s) continue;
      const std::array<int, 6> touched = move.or_opt ? std::array{move.p, move.s1, move.sl, move.nx, move.c, move.d}
                                                     : std::array{move.a, move.b, move.c, move.d, -1, -1};
      apply(move);
      for (int node : touched)
        if (node >= 0 && !queued[node]) {
          queued[node] = 1;
          queue.push_back(node);
        }
      if (++moves == max_moves) return;
    }
  }

  // The sites from start to end.
  std::vector<int> path() const {
    std::vector<int> sites;
    const bool forward = next(start_) != end_;
    for (int v = forward ? next(start_) : prev(start_); v != end_; v = forward ? next(v) : prev(v))
      sites.push_back(v);
    return sites;
  }

 private:
  int size() const { return static_cast<int>(tour_.size()); }
  int next(int v) const { return tour_[(position_[v] + 1) % size()]; }
  int prev(int v) const { return tour_[(position_[v] + size() - 1) % size()]; }
  int step(int v, bool forward) const { return forward ? next(v) : prev(v); }
  bool fixed(int v) const { return v >= start_; }
  bool locked(int u, int v) const { return fixed(u) && fixed(v); }
  const int* candidates(int v) const { return &candidates_[static_cast<std::size_t>(v) * stride_]; }

  double w(int u, int v) const {
    if (open_end_ && (u == end_ || v == end_)) return 0;
    const double dx = coordinates_[2 * u] - coordinates_[2 * v], dy = coordinates_[2 * u + 1] - coordinates_[2 * v + 1];
    return cost_.of_distance(std::sqrt(dx * dx + dy * dy));
  }

  Move best_move(int v) const {
    Move best;
    improve_by_2opt(v, best);
    if (!fixed(v)) improve_by_or_opt(v, best);
    return best;
  }

  void improve_by_2opt(int a, Move& best) const {
    for (bool forward : {true, false}) {
      const int b = step(a, forward);
      if (locked(a, b)) continue;
      const double ab = w(a, b);
      for (int r = 0; r < stride_; ++r) {
        const int c = candidates(a)[r];
        if (c < 0) break;
        const double ac = w(a, c);
        if (ac >= ab) break;  // candidates come nearest first; farther ones cannot start a gain
        const int d = step(c, forward);
        if (c == b || d == a || locked(c, d)) continue;
        const double gain = ab + w(c, d) - ac - w(b, d);
        if (gain > best.gain) best = Move{gain, false, a, b, c, d};
      }
    }
  }

  // Segments of one to three sites starting at s1 in either direction, reinserted either way round
  // next to a candidate of one of their ends.
  void improve_by_or_opt(int s1, Move& best) const {
    for (bool forward : {true, false}) {
      int segment[3] = {s1, -1, -1};
      for (int length = 1; length <= 3; ++length) {
        if (length > 1) {
          segment[length - 1] = step(segment[length - 2], forward);
          if (fixed(segment[length - 1])) break;
        } else if (!forward) {
          continue;  // a single site is the same segment both ways
        }
        const int sl = segment[length - 1], p = step(s1, !forward), nx = step(sl, forward);
        const double removal_gain = w(p, s1) + w(sl, nx) - w(p, nx);
        if (removal_gain <= min_gain_s) continue;
        auto inside = [&](int x) { return x == segment[0] || x == segment[1] || x == segment[2]; };
        for (int e : {s1, sl}) {
          const int other = e == s1 ? sl : s1;
          for (int r = 0; r < stride_; ++r) {
            const int c = candidates(e)[r];
            if (c < 0) break;
            const double ce = w(c, e);
            if (ce >= removal_gain) break;
            if (inside(c)) continue;
            for (int d : {next(c), prev(c)}) {
              if (inside(d) || locked(c, d)) continue;
              const double gain = removal_gain + w(c, d) - ce - w(other, d);
              if (gain > best.gain) best = Move{gain, true, -1, -1, c, d, p, s1, sl, nx, e};
            }
          }
          if (length == 1) break;
        }
      }
    }
  }

  void apply(const Move& move) {
    if (move.or_opt)
      move_segment(move.p, move.s1, move.sl, move.nx, move.c, move.d, move.e);
    else
      exchange(move.a, move.b, move.c, move.d);
  }

  // Reverses the path from → to (in array order), or the rest of the cycle when that is shorter:
  // both give the same cycle, read the other way round.
  void reverse(int from, int to) {
    const int m = size();
    int i = position_[from], j = position_[to];
    int length = (j - i + m) % m + 1;
    if (2 * length > m) {
      std::swap(i, j);
      i = (i + 1) % m;
      j = (j + m - 1) % m;
      length = m - length;
    }
    for (int k = 0; k < length / 2; ++k) {
      const int x = (i + k) % m, y = (j - k + m) % m;
      std::swap(tour_[x], tour_[y]);
      position_[tour_[x]] = x;
      position_[tour_[y]] = y;
    }
  }

  // 2-opt: (a, b), (c, d) → (a, c), (b, d), whichever way round the array reads the cycle.
  void exchange(int a, int b, int c, [[maybe_unused]] int d) {  // d is implied: the neighbour of c like b of a
    if (next(a) == b)
      reverse(b, c);
    else
      reverse(c, b);
  }

  // Or-opt as two or three 2-opt moves. Reading the cycle so that it goes p s1 … sl nx … c d …:
  // the first move gives p c … nx sl … s1 d, the second p nx … c sl … s1 d, and a third turns the
  // segment round when c should meet s1 instead.
  void move_segment(int p, int s1, int sl, int nx, int c, int d, int e) {
    const bool forward = next(p) == s1;
    int c1 = c, d1 = d;
    if (step(c1, forward) != d1) std::swap(c1, d1);
    if (d1 == p) {  // read the cycle the other way: the insertion edge then starts at the new nx
      std::swap(p, nx);
      std::swap(s1, sl);
      d1 = c1;
      c1 = nx;
    }
    exchange(p, s1, c1, d1);
    if (c1 != nx) exchange(p, c1, nx, sl);
    if (s1 != sl && next(c) != e && prev(c) != e) {
      const int near = next(c) == s1 || prev(c) == s1 ? s1 : sl;
      exchange(c, near, near == s1 ? sl : s1, d);
    }
  }

  const double* coordinates_;  // x, y of each node, contiguous: the hot loop skips Eigen (slow unoptimised)
  const TravelCost& cost_;
  const bool open_end_;
  const std::vector<int>& candidates_;
  const int stride_;
  int start_ = 0, end_ = 1;
  std::vector<int> tour_;      // node at each position
  std::vector<int> position_;  // position of each node
};

void check_inputs(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& home) {
  if (!home.allFinite()) throw std::invalid_argument("order_touches: home has a non-finite coordinate");
  for (const Eigen::Vector2d& p : points)
    if (!p.allFinite()) throw std::invalid_argument("order_touches: point with a non-finite coordinate");
}

}  // namespace

std::vector<int> order_touches(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& home,
                               const TravelCost& cost, const OrderOptions& options) {
  check_inputs(points, home);
  const Sites sites = distinct_sites(points);
  const int n = static_cast<int>(sites.xy.size());
  // Nodes: sites 0 … n−1, start n, end n+1 (home again, or a free end at zero cost).
  std::vector<Eigen::Vector2d> xy = sites.xy;
  xy.push_back(home);
  xy.push_back(home);
  const bool open_end = !options.return_home;
  const int k = std::max(1, options.neighbours);
  const int stride = k + (open_end ? 1 : 0);
  std::vector<int> nodes(n + (open_end ? 1 : 2));  // the free end has no place: it is near everything
  std::iota(nodes.begin(), nodes.end(), 0);
  const std::vector<int> candidates = candidate_lists(xy, nodes, k, open_end ? n + 1 : -1, stride);

  PathImprover improver(xy, cost, open_end, candidates, stride, nearest_neighbour_path(xy, n, n, candidates, stride));
  const double seconds = options.improve_time_s > 0 ? std::min(options.improve_time_s, 1e6) : 0.0;  // NaN → 0
  const auto budget = std::chrono::duration<double>(seconds);
  improver.improve(Clock::now() + std::chrono::duration_cast<Clock::duration>(budget), options.max_moves);

  std::vector<int> order;
  order.reserve(points.size());
  for (int site : improver.path())
    order.insert(order.end(), sites.members.begin() + sites.first[site], sites.members.begin() + sites.first[site + 1]);
  std::vector<int> input_order(points.size());
  std::iota(input_order.begin(), input_order.end(), 0);
  if (travel_time(points, home, input_order, cost, options.return_home) <
      travel_time(points, home, order, cost, options.return_home))
    return input_order;
  return order;
}

double travel_time(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& home,
                   const std::vector<int>& order, const TravelCost& cost, bool return_home) {
  double total = 0;
  const Eigen::Vector2d* at = &home;
  for (int i : order) {
    total += cost(*at, points.at(i));
    at = &points[i];
  }
  if (return_home) total += cost(*at, home);
  return total;
}

}  // namespace cmm::planner
