// Front edges are the facets' half-edges without a twin, linked into loops by prev/next so that a
// pinched vertex keeps each of its fans apart; a directed-edge map makes every topology test O(1).
// Geometry tests run in the plane halfway between the facet grown from and the new one, which
// unfolds a crease instead of folding one face onto the other.
#include "geometry/advancing_front.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "geometry/point_grid.hpp"

namespace cmm::geometry {
namespace {

std::uint64_t directed(int from, int to) { return (std::uint64_t(std::uint32_t(from)) << 32) | std::uint32_t(to); }
std::uint64_t undirected(int a, int b) { return a < b ? directed(a, b) : directed(b, a); }

using Vec2 = Eigen::Vector2d;

double cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }
double orient(const Vec2& a, const Vec2& b, const Vec2& c) { return cross2(b - a, c - a); }

// Clockwise turn from direction d1 to d2, in [0, 2π).
double clockwise(const Vec2& d1, const Vec2& d2) {
  const double a = std::atan2(-cross2(d1, d2), d1.dot(d2));
  return a < 0 ? a + 2 * std::numbers::pi : a;
}

bool segments_cross(const Vec2& p1, const Vec2& p2, const Vec2& q1, const Vec2& q2) {
  const double o1 = orient(p1, p2, q1), o2 = orient(p1, p2, q2), o3 = orient(q1, q2, p1), o4 = orient(q1, q2, p2);
  return ((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0));
}

struct Frame {  // the projection plane of one test
  Vec3 origin, t1, t2, normal;
  Vec2 operator()(const Vec3& x) const { return {(x - origin).dot(t1), (x - origin).dot(t2)}; }
  double height(const Vec3& x) const { return (x - origin).dot(normal); }
};

Frame frame_at(const Vec3& origin, const Vec3& normal) {
  const Vec3 t1 = normal.unitOrthogonal();
  return {origin, t1, normal.cross(t1), normal};
}

class Grower {
 public:
  Grower(const Points& x, const std::vector<VertexSurface>& surfaces, const std::vector<Vec3>& seed_normals,
         const std::vector<char>& can_seed, const std::vector<CreaseEdge>& creases, const FrontOptions& options)
      : x_(x),
        surfaces_(surfaces),
        seed_normals_(seed_normals),
        can_seed_(can_seed),
        options_(options),
        max_edge_(options.reach_mm.empty() ? options.max_edge_bins * options.bin_mm
                                           : std::max(options.max_edge_bins * options.bin_mm,
                                                      *std::max_element(options.reach_mm.begin(), options.reach_mm.end()))),
        cos_min_angle_(std::cos(options.min_angle_deg * std::numbers::pi / 180)),
        cos_fold_(std::cos(options.fold_angle_deg * std::numbers::pi / 180)),
        grid_(x, std::max(options.max_edge_bins * options.bin_mm, 1e-300)),
        out_head_(static_cast<std::size_t>(x.rows()), -1),
        used_(static_cast<std::size_t>(x.rows()), 0) {
    for (std::size_t i = 0; i < creases.size(); ++i) creases_.emplace(undirected(creases[i].a, creases[i].b), creases[i]);
    half_.reserve(static_cast<std::size_t>(x.rows()) * 7);
    base_edge_ = options.max_edge_bins * options.bin_mm;
    if (!options.reach_mm.empty()) {
      sparse_.assign(options.reach_mm.size(), 0);
      for (std::size_t v = 0; v < options.reach_mm.size(); ++v)
        if (options.reach_mm[v] > base_edge_) sparse_[v] = 1, sparse_ids_.push_back(static_cast<int>(v));
      if (!sparse_ids_.empty()) {
        sparse_x_.resize(static_cast<Eigen::Index>(sparse_ids_.size()), 3);
        for (std::size_t i = 0; i < sparse_ids_.size(); ++i) sparse_x_.row(static_cast<Eigen::Index>(i)) = x.row(sparse_ids_[i]);
        sparse_grid_.emplace(sparse_x_, 2 * max_edge_);  // cells as wide as its searches: few to visit
        // A long edge can cross only a facet with a corner within three of the longest edges of its ends.
        near_sparse_.assign(static_cast<std::size_t>(x.rows()), 0);
        for (Eigen::Index v = 0; v < x.rows(); ++v)
          sparse_grid_->for_each_within(x.row(v).transpose(), 3 * max_edge_, [&](int, double) { near_sparse_[static_cast<std::size_t>(v)] = 1; });
      }
    }
  }

  FrontResult run() {
    FrontResult result;
    const std::size_t cap = 3 * static_cast<std::size_t>(x_.rows()) + 16;
    for (int v = 0; v < x_.rows(); ++v) {
      if (used_[v] || !can_seed_[v] || !seed(v)) continue;
      ++result.seeds;
      while (!queue_.empty() && facets_.size() < cap) {
        const int e = queue_.front();
        queue_.pop_front();
        if (!edges_[e].alive || edges_[e].boundary) continue;
          if (!advance(e)) edges_[e].boundary = true;
      }
      queue_.clear();
      if (facets_.size() >= cap) break;
    }
    result.faces.resize(static_cast<Eigen::Index>(facets_.size()), 3);
    for (std::size_t f = 0; f < facets_.size(); ++f)
      for (int k = 0; k < 3; ++k) result.faces(static_cast<Eigen::Index>(f), k) = facets_[f][k];
    for (int v = 0; v < x_.rows(); ++v) {
      int fans = 0;
      for (int e = out_head_[v]; e >= 0; e = edges_[e].next_out) ++fans;
      if (fans > 1) ++result.pinched_vertices;
    }
    return result;
  }

 private:
  struct Edge {
    int from = 0, to = 0, prev = -1, next = -1, facet = 0, next_out = -1;
    bool alive = true, boundary = false;
  };

  // How the new facet (a, q, b) meets the front: which twins it consumes, which fan of q it joins.
  struct Join {
    int q = -1;
    bool consume_prev = false, consume_next = false;
    int q_in = -1, q_out = -1;  // q's front edges around the fan it joins (−1: q is a free point)
    Vec3 normal;
  };

  Vec3 at(int v) const { return x_.row(v).transpose(); }

  bool agrees(int v, const Vec3& n) const {
    const VertexSurface& s = surfaces_[v];
    for (int k = 0; k < s.count; ++k)
      if (std::abs(s.normals[k].dot(n)) >= s.cos_tolerance) return true;
    return s.count == 0;
  }

  // More of the facet's corners face against it than with it, by the scanner's normals.
  bool inside_out(int a, int q, int b, const Vec3& n) const {
    if (!options_.seed_normals_oriented) return false;
    int against = 0, along = 0;
    for (const int v : {a, q, b}) {
      const double d = seed_normals_[v].dot(n);  // zero where the vertex has no seed normal (a crease point)
      if (d < -0.5) ++against;
      if (d > 0.5) ++along;
    }
    return against > along;
  }

  // Two points of one crease are joined along it only by its own edges: a chord would skip a crease point.
  bool skips_crease(int u, int w) const {
    const int cu = surfaces_[u].crease, cw = surfaces_[w].crease;
    if (cu == -1 || cw == -1 || (cu >= 0 && cw >= 0 && cu != cw)) return false;
    return !creases_.contains(undirected(u, w));
  }

  // Thesis §4.2.2 (2): every angle of the facet at least the minimum.
  static bool well_shaped(const Vec3& a, const Vec3& b, const Vec3& c, double cos_min_angle) {
    const Vec3 p[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      const Vec3 u = p[(k + 1) % 3] - p[k], w = p[(k + 2) % 3] - p[k];
      const double nu = u.norm(), nw = w.norm();
      if (nu == 0 || nw == 0 || u.dot(w) > cos_min_angle * nu * nw) return false;
    }
    return true;
  }

  int add_edge(int from, int to, int facet) {
    const int id = static_cast<int>(edges_.size());
    const double length = (at(to) - at(from)).norm();
    longest_edge_ = std::max(longest_edge_, length);
    // An edge with a sparse end is found from that end on the sparse grid (clear_of_front).
    if (!sparse(from) && !sparse(to)) longest_dense_edge_ = std::max(longest_dense_edge_, length);
    Edge e;
    e.from = from;
    e.to = to;
    e.facet = facet;
    e.next_out = out_head_[from];
    out_head_[from] = id;
    edges_.push_back(e);
    half_[directed(from, to)] = id;
    queue_.push_back(id);
    return id;
  }

  void kill_edge(int id) {
    Edge& e = edges_[id];
    e.alive = false;
    half_[directed(e.from, e.to)] = -1;
    for (int* link = &out_head_[e.from]; *link >= 0; link = &edges_[*link].next_out)
      if (*link == id) {
        *link = e.next_out;
        break;
      }
  }

  void link(int first, int second) {
    edges_[first].next = second;
    edges_[second].prev = first;
  }

  // A boundary edge next to the change may have a suitable point now.
  void wake(int e) {
    if (e >= 0 && edges_[e].alive && edges_[e].boundary) {
      edges_[e].boundary = false;
      queue_.push_back(e);
    }
  }

  int half(int from, int to) const {  // −2: no such half-edge; −1: inside; else the front edge
    const auto it = half_.find(directed(from, to));
    return it == half_.end() ? -2 : it->second;
  }

  // The new facet's corner at v stays within v's free wedge between its front edges `out` (to x)
  // and `in` (from w); f1 then f2 are the facet's other corners, clockwise. Seen along the mean of the
  // three facets' normals, which unfolds a crease the front turns at instead of folding one face onto
  // the crease line.
  bool in_wedge(int v, int out, int in, const Vec3& f1, const Vec3& f2, const Vec3& normal) const {
    Vec3 n = normal + facet_normals_[edges_[out].facet] + facet_normals_[edges_[in].facet];
    n = n.norm() > 1e-6 ? Vec3(n.normalized()) : normal;
    const Frame fr = frame_at(at(v), n);
    const Vec2 dx = fr(at(edges_[out].to));
    const double a1 = clockwise(dx, fr(f1)), a2 = clockwise(dx, fr(f2));
    const bool full = edges_[out].to == edges_[in].from;
    const double limit = full ? 2 * std::numbers::pi : clockwise(dx, fr(at(edges_[in].from)));
    return a1 <= a2 && a2 <= limit;
  }

  bool facing(int edge, const Frame& fr) const { return facet_normals_[edges_[edge].facet].dot(fr.normal) > 0.2; }

  // No front edge nearby crosses the new edges, no front vertex lies in the facet.
  bool clear_of_front(const Frame& fr, int a, int q, int b, bool new_aq, bool new_qb, bool new_ba) const {
    const Vec2 pa = fr(at(a)), pq = fr(at(q)), pb = fr(at(b));
    const double span = std::max({(at(q) - fr.origin).norm(), (at(a) - fr.origin).norm(), (at(b) - fr.origin).norm()});
    const double slab = 0.75 * local_edge(a, q, b);
    const double scale = (pa - pq).squaredNorm() + (pb - pq).squaredNorm();
    bool clear = true;
    const auto visit = [&](int v, double) {
      if (!clear || out_head_[v] < 0) return;
      if (std::abs(fr.height(at(v))) > slab) return;
      for (int o = out_head_[v]; o >= 0 && clear; o = edges_[o].next_out) {
        for (int e : {o, edges_[o].prev}) {
          if (!facing(e, fr)) continue;
          const int u = edges_[e].from, w = edges_[e].to;
          const Vec2 pu = fr(at(u)), pw = fr(at(w));
          const auto touches = [&](int s, int t) { return u == s || u == t || w == s || w == t; };
          if ((new_aq && !touches(a, q) && segments_cross(pa, pq, pu, pw)) ||
              (new_qb && !touches(q, b) && segments_cross(pq, pb, pu, pw)) ||
              (new_ba && !touches(b, a) && segments_cross(pb, pa, pu, pw)))
            clear = false;
        }
        if (clear && v != a && v != b && v != q && facing(o, fr)) {
          const Vec2 pv = fr(at(v));
          const double eps = -1e-12 * scale;
          if (orient(pa, pq, pv) > eps && orient(pq, pb, pv) > eps && orient(pb, pa, pv) > eps) clear = false;
        }
      }
    };
    // A crossing edge has an end within the span and its own length of the origin. Edges longer than
    // any between two dense points have a sparse end, which a grid of their own finds: the dense grid is
    // searched no wider than its own edges need.
    grid_.for_each_within(fr.origin, span + longest_dense_edge_, visit);
    if (sparse_grid_ && longest_edge_ > longest_dense_edge_ && near_sparse_[static_cast<std::size_t>(a)])
      sparse_grid_->for_each_within(fr.origin, span + longest_edge_, [&](int i, double d2) { visit(sparse_ids_[static_cast<std::size_t>(i)], d2); });
    return clear;
  }

  // The suitable-point rules (§4.2.2) and the overlap guard for q against front edge e (a→b).
  std::optional<Join> suitable(int e, int q) const {
    const Edge& E = edges_[e];
    const int a = E.from, b = E.to;
    const Vec3 xa = at(a), xb = at(b), xq = at(q);
    // A triangular gap is closed whatever its angles: left open, it would be a false hole.
    const bool closes_gap = half(q, a) == E.prev && half(b, q) == E.next;
    if (!well_shaped(xa, xq, xb, closes_gap ? cos_closing_angle_ : cos_min_angle_)) return {};
    if (skips_crease(a, q) || skips_crease(q, b)) return {};
    Join j;
    j.q = q;
    j.normal = (xq - xa).cross(xb - xa).normalized();
    const Vec3& n_adj = facet_normals_[E.facet];
    const auto crease = creases_.find(undirected(a, b));
    if (crease != creases_.end()) {
      // Across a crease the facet must lie on the other face, not continue the one grown from.
      const CreaseEdge& c = crease->second;
      const Vec3& other = std::abs(n_adj.dot(c.normal_a)) >= std::abs(n_adj.dot(c.normal_b)) ? c.normal_b : c.normal_a;
      if (std::abs(j.normal.dot(other)) < c.cos_tolerance || j.normal.dot(n_adj) < -0.95) return {};
    } else if (j.normal.dot(n_adj) < (closes_gap ? 0.0 : cos_fold_)) {
      return {};
    }
    // A sliver's normal says little: closing a gap it need only not fold back.
    if (!closes_gap && (!agrees(a, j.normal) || !agrees(b, j.normal) || !agrees(q, j.normal))) return {};
    if (!closes_gap && inside_out(a, q, b, j.normal)) return {};

    // Topology: each directed edge once; a twin consumed only where it closes a gap (§4.3 c).
    if (half(a, q) != -2 || half(q, b) != -2) return {};
    const int twin_qa = half(q, a), twin_bq = half(b, q);
    if (twin_qa != -2) {
      if (twin_qa != E.prev) return {};
      j.consume_prev = true;
    }
    if (twin_bq != -2) {
      if (twin_bq != E.next) return {};
      j.consume_next = true;
    }
    const Frame fr = frame_at(0.5 * (xa + xb), (n_adj + j.normal).normalized());
    if (!in_wedge(a, e, E.prev, xb, xq, j.normal)) return {};
    if (!in_wedge(b, E.next, e, xq, xa, j.normal)) return {};
    if (used_[q]) {
      if (out_head_[q] < 0) return {};  // inside the mesh
      const auto fits = [&](int in, int out) { return in_wedge(q, out, in, xa, xb, j.normal); };
      if (j.consume_prev) {
        j.q_out = E.prev;
        j.q_in = edges_[E.prev].prev;
      } else if (j.consume_next) {
        j.q_in = E.next;
        j.q_out = edges_[E.next].next;
      } else {
        for (int o = out_head_[q]; o >= 0; o = edges_[o].next_out)
          if (fits(edges_[o].prev, o)) {
            j.q_in = edges_[o].prev;
            j.q_out = o;
            break;
          }
        if (j.q_out < 0) return {};
      }
      if (!fits(j.q_in, j.q_out)) return {};
    }
    if (!clear_of_front(fr, a, q, b, !j.consume_prev, !j.consume_next, false)) return {};
    return j;
  }

  int add_facet(int a, int b, int c, const Vec3& normal) {
    facets_.push_back({a, b, c});
    facet_normals_.push_back(normal);
    used_[a] = used_[b] = used_[c] = 1;
    if (facets_.size() % 4096 == 0) options_.cancel.throw_if_requested("triangulation");
    return static_cast<int>(facets_.size()) - 1;
  }

  // §4.3 b–d: the front loses the searching edge and the twins the facet consumes, gains its new
  // edges, and is relinked so a loop closes, splits off a hole or merges with another loop.
  void attach(int e, const Join& j) {
    const Edge E = edges_[e];
    const int a = E.from, b = E.to, q = j.q, ea = E.prev, eb = E.next;
    const int f = add_facet(a, q, b, j.normal);
    half_[directed(b, a)] = -1;
    kill_edge(e);
    if (j.consume_prev && j.consume_next) {  // a triangular loop closes
      half_[directed(a, q)] = half_[directed(q, b)] = -1;
      kill_edge(ea);
      kill_edge(eb);
      return;
    }
    if (j.consume_prev) {
      const int before = edges_[ea].prev;
      half_[directed(a, q)] = -1;
      kill_edge(ea);
      const int e2 = add_edge(q, b, f);
      link(before, e2);
      link(e2, eb);
      wake(before);
      wake(eb);
      return;
    }
    if (j.consume_next) {
      const int after = edges_[eb].next;
      half_[directed(q, b)] = -1;
      kill_edge(eb);
      const int e1 = add_edge(a, q, f);
      link(ea, e1);
      link(e1, after);
      wake(ea);
      wake(after);
      return;
    }
    const int e1 = add_edge(a, q, f), e2 = add_edge(q, b, f);
    link(ea, e1);
    if (j.q_out < 0) {
      link(e1, e2);
    } else {  // q was on the front: the loop splits (a hole, §4.3 d) or two loops merge
      link(e1, j.q_out);
      link(j.q_in, e2);
      wake(j.q_out);
      wake(j.q_in);
    }
    link(e2, eb);
    wake(ea);
    wake(eb);
  }

  // Edges of the loop through e, counted up to `limit`.
  int loop_length(int e, int limit) const {
    int n = 1;
    for (int f = edges_[e].next; f != e && n <= limit; f = edges_[f].next) ++n;
    return n;
  }

  // An edge a–b is no longer than either end's reach: each end's bin says how long a chord its surface
  // allows at ε. (The larger reach put coarse edges over the curved side of a level change, 0.04 mm
  // off at ε 0.01; the graded levels leave no gap with the smaller.)
  bool within_reach(int a, int b) const {
    const double reach = options_.reach_mm.empty()       ? max_edge_
                         : options_.larger_reach_joins ? std::max(options_.reach_mm[a], options_.reach_mm[b])
                                                         : std::min(options_.reach_mm[a], options_.reach_mm[b]);
    return (at(a) - at(b)).squaredNorm() <= reach * reach;
  }

  bool advance(int e) {
    const Edge& E = edges_[e];
    const Vec3 xa = at(E.from), xb = at(E.to), m = 0.5 * (xa + xb);
    candidates_.clear();
    // A point within reach of both ends lies within the mean of their reaches of the edge's midpoint, or
    // with the larger reach joining, within a sparse point's reach where one is near.
    const bool sparse_near = options_.larger_reach_joins && !near_sparse_.empty() &&
                             (near_sparse_[static_cast<std::size_t>(E.from)] || near_sparse_[static_cast<std::size_t>(E.to)]);
    const double search = options_.reach_mm.empty() || sparse_near ? max_edge_ : 0.5 * (options_.reach_mm[E.from] + options_.reach_mm[E.to]);
    grid_.for_each_within(m, search, [&](int q, double d2) {
      if (q == E.from || q == E.to || (used_[q] && out_head_[q] < 0)) return;
      if (!within_reach(q, E.from) || !within_reach(q, E.to)) return;
      candidates_.emplace_back(d2, q);
    });
    // A small loop may be closed by a diagonal longer than any new edge may be: left, it is a false hole.
    if (loop_length(e, 6) <= 6)
      for (const int q : {edges_[E.prev].from, edges_[E.next].to}) {
        const bool listed = std::any_of(candidates_.begin(), candidates_.end(), [&](const auto& c) { return c.second == q; });
        if (const double longest = 2 * local_edge(E.from, E.to, q);
            !listed && q != E.from && q != E.to && (at(q) - xa).norm() <= longest && (at(q) - xb).norm() <= longest)
          candidates_.emplace_back((at(q) - m).squaredNorm(), q);
      }
    std::sort(candidates_.begin(), candidates_.end());
    for (const auto& [d2, q] : candidates_)
      if (const auto j = suitable(e, q)) {
        attach(e, *j);
        return true;
      }
    return false;
  }

  // §4.2.1: the seed's nearest point, then the point nearest their midpoint that makes a good facet.
  bool seed(int s) {
    const Vec3 xs = at(s);
    std::vector<std::pair<double, int>> near;
    grid_.for_each_within(xs, options_.reach_mm.empty() ? max_edge_ : options_.reach_mm[s], [&](int q, double d2) {
      if (q != s && !used_[q] && within_reach(q, s)) near.emplace_back(d2, q);
    });
    std::sort(near.begin(), near.end());
    Vec3 up = seed_normals_[s];
    if (up.squaredNorm() == 0) up = surfaces_[s].normals[0];
    for (std::size_t i = 0; i < near.size() && i < 3; ++i) {
      const int q1 = near[i].second;
      const Vec3 m = 0.5 * (xs + at(q1));
      std::vector<std::pair<double, int>> third;
      for (const auto& [d2, q] : near)
        if (q != q1 && within_reach(q, q1)) third.emplace_back((at(q) - m).squaredNorm(), q);
      std::sort(third.begin(), third.end());
      for (const auto& [d2, q2] : third) {
        int b = q1, c = q2;
        Vec3 n = (at(b) - xs).cross(at(c) - xs);
        if (n.dot(up) < 0) std::swap(b, c), n = -n;
        if (!well_shaped(xs, at(b), at(c), cos_min_angle_) || skips_crease(s, b) || skips_crease(b, c) || skips_crease(c, s)) continue;
        n.normalize();
        if (!agrees(s, n) || !agrees(b, n) || !agrees(c, n)) continue;
        const Frame fr = frame_at((xs + at(b) + at(c)) / 3, n);
        if (!clear_of_front(fr, s, b, c, true, true, true) || holds_a_point(fr, s, b, c)) continue;
        const int f = add_facet(s, b, c, n);
        const int e0 = add_edge(s, b, f), e1 = add_edge(b, c, f), e2 = add_edge(c, s, f);
        link(e0, e1);
        link(e1, e2);
        link(e2, e0);
        return true;
      }
    }
    return false;
  }

  // A seed keeps no point inside it (§4.2.1).
  bool holds_a_point(const Frame& fr, int a, int b, int c) const {
    const Vec2 pa = fr(at(a)), pb = fr(at(b)), pc = fr(at(c));
    bool holds = false;
    const double edge = local_edge(a, b, c);
    grid_.for_each_within(fr.origin, edge, [&](int v, double) {
      if (v == a || v == b || v == c || std::abs(fr.height(at(v))) > 0.5 * edge) return;
      const Vec2 p = fr(at(v));
      if (orient(pa, pb, p) > 0 && orient(pb, pc, p) > 0 && orient(pc, pa, p) > 0) holds = true;
    });
    return holds;
  }

  const Points& x_;
  const std::vector<VertexSurface>& surfaces_;
  const std::vector<Vec3>& seed_normals_;
  const std::vector<char>& can_seed_;
  const FrontOptions& options_;
  const double max_edge_, cos_min_angle_, cos_closing_angle_ = std::cos(2 * std::numbers::pi / 180), cos_fold_;
  PointGrid grid_;
  std::unordered_map<std::uint64_t, CreaseEdge> creases_;
  std::vector<std::array<int, 3>> facets_;
  std::vector<Vec3> facet_normals_;
  std::vector<Edge> edges_;
  std::vector<int> out_head_;
  std::vector<char> used_;
  std::unordered_map<std::uint64_t, int> half_;
  std::deque<int> queue_;
  std::vector<std::pair<double, int>> candidates_;
  double longest_edge_ = 0;  // of any front edge so far: how far a crossing edge's ends can be
  double longest_dense_edge_ = 0;  // of those with no sparse end
  double base_edge_;               // max_edge_bins · bin_mm: a point's reach unless reach_mm says more
  std::vector<char> sparse_;       // per vertex: its reach is beyond base_edge_ (a sparse face's point)
  Points sparse_x_;                // those vertices, for their own grid
  std::vector<int> sparse_ids_;
  std::optional<PointGrid> sparse_grid_;
  std::vector<char> near_sparse_;  // per vertex: a sparse point lies within 3·max_edge_

  bool sparse(int v) const { return !sparse_.empty() && sparse_[static_cast<std::size_t>(v)]; }
  // The longest edge a facet on these corners may have: B's, or more where one is a sparse face's point
  // (so a dense face is grown and checked as if no face were sparse).
  double local_edge(int a, int b, int c) const {
    if (sparse_ids_.empty()) return max_edge_;
    return std::max({base_edge_, options_.reach_mm[static_cast<std::size_t>(a)], options_.reach_mm[static_cast<std::size_t>(b)],
                     options_.reach_mm[static_cast<std::size_t>(c)]});
  }
};

}  // namespace

FrontResult grow_front(const Points& vertices, const std::vector<VertexSurface>& surfaces,
                       const std::vector<Vec3>& seed_normals, const std::vector<char>& can_seed,
                       const std::vector<CreaseEdge>& creases, const FrontOptions& options) {
  if (vertices.rows() < 3 || !(options.bin_mm > 0)) return {};
  if (!options.reach_mm.empty() && options.reach_mm.size() != static_cast<std::size_t>(vertices.rows()))
    throw std::invalid_argument("grow_front: " + std::to_string(options.reach_mm.size()) + " reaches for " +
                                std::to_string(vertices.rows()) + " vertices");
  return Grower(vertices, surfaces, seed_normals, can_seed, creases, options).run();
}

}  // namespace cmm::geometry
