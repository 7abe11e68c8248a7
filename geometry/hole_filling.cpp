// fill_false_holes: each short loop (split at pinched vertices) is filled flat by ear clipping in its
// plane, or, where its sides lie on two faces meeting at a crease, on each face up to a chain of new
// vertices on the faces' intersection line, so the crease stays sharp. A patch is kept only when the
// raw cloud lies along it: an opening of the scanned region has no scan points across it.
#include "geometry/hole_filling.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <Eigen/Eigenvalues>

#include "geometry/bin_size.hpp"
#include "geometry/boundary_loops.hpp"
#include "geometry/edge_adjacency.hpp"
#include "geometry/least_folding_patch.hpp"
#include "geometry/polygon_triangulation.hpp"

namespace cmm::geometry {
namespace {

using Face = std::array<int, 3>;

constexpr std::size_t kMaxPatchFaces = 2000;  // a curved patch bigger than this is no gap
constexpr double kMinPatchAngle = 10 * std::numbers::pi / 180;  // region growing's smallest facet angle
constexpr std::size_t kMaxLeastFoldingLoop = 300;  // O(n³): about 0.1 s at this size
constexpr double kMaxPatchFold = 160 * std::numbers::pi / 180;  // folding onto itself: an outline's patch
// The mean cosine between the patch's normal and its rim facets' normals: about 0.7 across a right-angled
// crease, 0.29 over the end of the plate's slot (its wall a half circle of 3 B: the normals fan out),
// below 0 for an outline's (a second sheet over the surface).
constexpr double kMinPatchFacing = 0.15;
// The cosine each facet of a least-folding patch must reach with some facet of its rim.
constexpr double kMinFacetFacing = 0.5;
// How much more a refined least-folding patch may fold than its triangulation did before its new
// vertices were put onto the raw surface (noise on a flat patch tilts facets by a few degrees).
constexpr double kPatchRefineFold = 30 * std::numbers::pi / 180;
constexpr double kMaxStripWidthBins = 3;  // a loop longer than a short one's limit is a strip up to this wide
constexpr double kStripApartBins = 6;     // measured to vertices at least this far along the loop
constexpr std::size_t kMaxStripPiece = 150;
constexpr std::size_t kMaxStripVertices = 4000;  // about 2,000 B long: the plate's whole back edge is 747
constexpr double kMaxRungBins = 4;

std::uint64_t directed_key(int from, int to) { return (std::uint64_t(std::uint32_t(from)) << 32) | std::uint32_t(to); }

std::uint64_t edge_key(int a, int b) { return a < b ? directed_key(a, b) : directed_key(b, a); }

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

bool segments_cross(const Eigen::Vector2d& p1, const Eigen::Vector2d& p2, const Eigen::Vector2d& q1,
                    const Eigen::Vector2d& q2) {
  const double o1 = cross2(p2 - p1, q1 - p1), o2 = cross2(p2 - p1, q2 - p1);
  const double o3 = cross2(q2 - q1, p1 - q1), o4 = cross2(q2 - q1, p2 - q1);
  return ((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0));
}

// Non-adjacent sides neither cross nor share a point: ear clipping needs a simple polygon.
bool simple(const Polygon2d& p) {
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      if ((p[i] - p[j]).squaredNorm() == 0) return false;
      if (j >= i + 2 && !(i == 0 && j == n - 1) && segments_cross(p[i], p[(i + 1) % n], p[j], p[(j + 1) % n])) return false;
    }
  return true;
}

// A loop through a vertex twice is split there into simple cycles, each in the loop's order.
std::vector<std::vector<int>> simple_cycles(const std::vector<int>& loop) {
  std::vector<std::vector<int>> out;
  std::vector<int> stack;
  for (int v : loop) {
    const auto at = std::find(stack.begin(), stack.end(), v);
    if (at == stack.end()) {
      stack.push_back(v);
      continue;
    }
    std::vector<int> cycle(at, stack.end());
    if (cycle.size() >= 3) out.push_back(std::move(cycle));
    stack.erase(at + 1, stack.end());
  }
  if (stack.size() >= 3) out.push_back(std::move(stack));
  return out;
}

// A loop no patch closed whose rim facets are cut back for another round: a short one (a folded pinhole
// rim), or one up to pinhole_loop_bins with raw points at its middle (a tangle where a rim curves at a few
// bins or two views' sheets meet; an opening's mouth is empty across its whole width).
bool recut(const std::vector<Vec3>& loop, double perimeter, const CloudIndex& raw_index, const HoleFillingOptions& options) {
  if (perimeter <= options.small_loop_bins * options.bin_mm) return true;
  if (perimeter > options.pinhole_loop_bins * options.bin_mm || loop.empty()) return false;
  Vec3 middle = Vec3::Zero();
  for (const Vec3& p : loop) middle += p / static_cast<double>(loop.size());
  return !raw_index.within(middle, options.max_gap_bins * options.bin_mm).empty();
}

class Filler {
 public:
  // `last_round`: no loop is cut back after this round.
  Filler(TriangleMesh& mesh, const Points& raw, const CloudIndex& raw_index, const HoleFillingOptions& options, bool last_round)
      : mesh_(mesh), raw_(raw), index_(raw_index), options_(options), bin_(options.bin_mm), old_vertices_(static_cast<int>(mesh.vertices.rows())),
        last_round_(last_round) {
    const EdgeAdjacency adjacency = edge_adjacency(mesh);
    for (Eigen::Index e = 0; e < adjacency.edges.rows(); ++e) edges_.insert(edge_key(adjacency.edges(e, 0), adjacency.edges(e, 1)));
    normals_.assign(static_cast<std::size_t>(mesh.vertices.rows()), Vec3::Zero());
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
      const Vec3 a = vertex(mesh, mesh.faces(f, 0)), b = vertex(mesh, mesh.faces(f, 1)), c = vertex(mesh, mesh.faces(f, 2));
      const Vec3 n2 = (b - a).cross(c - a);
      for (int k = 0; k < 3; ++k) normals_[mesh.faces(f, k)] += n2;
    }
    for (Vec3& n : normals_)
      if (n.norm() > 0) n.normalize();
    dump_ = std::getenv("CMMD_DUMP_FILL") != nullptr;
    for (const BoundaryLoop& loop : boundary_loops(mesh, adjacency)) loops_.push_back(loop.vertices);
    // The normal of the facet beside each loop side, for the least-folding patch.
    for (const std::vector<int>& loop : loops_)
      for (std::size_t i = 0; i < loop.size(); ++i) rim_normals_.emplace(directed_key(loop[i], loop[(i + 1) % loop.size()]), Vec3::Zero());
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
      for (int k = 0; k < 3; ++k) {
        const auto side = rim_normals_.find(directed_key(mesh.faces(f, k), mesh.faces(f, (k + 1) % 3)));
        if (side == rim_normals_.end()) continue;
        const Vec3 a = vertex(mesh, mesh.faces(f, 0)), b = vertex(mesh, mesh.faces(f, 1)), c = vertex(mesh, mesh.faces(f, 2));
        side->second = (b - a).cross(c - a).normalized();
      }
  }

  HoleFilling run() {
    HoleFilling out;
    for (const std::vector<int>& loop : loops_) {
      for (const std::vector<int>& cycle : simple_cycles(loop)) {
        double perimeter = 0;
        for (std::size_t i = 0; i < cycle.size(); ++i) perimeter += (at(cycle[(i + 1) % cycle.size()]) - at(cycle[i])).norm();
        if (perimeter > options_.max_perimeter_bins * bin_) {
          // A long loop is no patch to guess, unless it is a thin strip (along a crease the growth did
          // not join: then every piece of it is as well known as a short loop, and cut into pieces its
          // patch stays in the faces) or short for the sparse face it lies in.
          if (thin_strip(cycle)) {
            ++out.loops_examined;
            if (fill_strip(cycle, perimeter)) ++out.loops_filled;
            continue;
          }
          if (perimeter > short_loop_limit(cycle)) {
            say(cycle, perimeter, "long, not a thin strip", 0);
            continue;
          }
        }
        ++out.loops_examined;
        if (fill(cycle, perimeter)) ++out.loops_filled;
      }
    }
    const Eigen::Index old_faces = mesh_.faces.rows();
    mesh_.faces.conservativeResize(old_faces + static_cast<Eigen::Index>(faces_.size()), 3);
    for (std::size_t f = 0; f < faces_.size(); ++f)
      for (int k = 0; k < 3; ++k) mesh_.faces(old_faces + static_cast<Eigen::Index>(f), k) = faces_[f][k];
    mesh_.vertices.conservativeResize(old_vertices_ + static_cast<Eigen::Index>(extra_.size()), 3);
    for (std::size_t i = 0; i < extra_.size(); ++i) mesh_.vertices.row(old_vertices_ + static_cast<Eigen::Index>(i)) = extra_[i].transpose();
    if (mesh_.vertex_normals.rows() > 0) mesh_.vertex_normals.resize(0, 3);
    out.faces_added = faces_.size();
    out.vertices_added = extra_.size();
    return out;
  }

 private:
  Vec3 at(int id) const { return id < old_vertices_ ? vertex(mesh_, id) : extra_[static_cast<std::size_t>(id - old_vertices_)]; }

  void say(const std::vector<int>& cycle, double perimeter, const char* what, double value) const {
    if (!dump_) return;
    Vec3 c = Vec3::Zero();
    for (int i : cycle) c += at(i) / static_cast<double>(cycle.size());
    std::printf("fill: loop %zu v %.2f mm at (%.1f %.1f %.1f): %s %.3f\n", cycle.size(), perimeter, c.x(), c.y(), c.z(), what, value);
  }

  // Ear clipping of `ids` (a polygon in loop order) seen along ±normal, the triangles wound against the
  // loop; no diagonal may already be an edge. A few starting corners are tried: each gives other diagonals.
  bool clip(const std::vector<int>& ids, Vec3 normal, const std::vector<Vec3>& x, std::vector<Face>& out) const {
    const std::size_t n = ids.size();
    Vec3 newell = Vec3::Zero(), around = Vec3::Zero();
    for (std::size_t i = 0; i < n; ++i) newell += x[i].cross(x[(i + 1) % n]);
    // The surface lies left of the loop: beside a hole it faces against the loop's Newell normal, beside
    // a patch's own outline with it. Filling an outline would lay a second sheet over the patch.
    for (int id : ids)
      if (id < old_vertices_) around += normals_[id];
    if (!(around.dot(newell) < 0)) return false;
    if (newell.dot(normal) < 0) normal = -normal;
    const Vec3 t1 = normal.unitOrthogonal(), t2 = normal.cross(t1);
    Polygon2d polygon;
    for (const Vec3& p : x) polygon.emplace_back((p - x[0]).dot(t1), (p - x[0]).dot(t2));
    if (!simple(polygon)) return false;
    for (std::size_t start = 0; start < std::min<std::size_t>(n, 6); ++start) {
      Polygon2d rotated(polygon.begin() + static_cast<std::ptrdiff_t>(start), polygon.end());
      rotated.insert(rotated.end(), polygon.begin(), polygon.begin() + static_cast<std::ptrdiff_t>(start));
      std::vector<std::array<int, 3>> triangles;
      try {
        triangles = triangulate_polygon(rotated, {});
      } catch (const std::invalid_argument&) {
        return false;
      }
      if (triangles.size() != n - 2) return false;
      bool fresh = true;
      std::vector<Face> faces;
      for (const auto& t : triangles) {
        const int i0 = static_cast<int>((t[0] + start) % n), i1 = static_cast<int>((t[1] + start) % n), i2 = static_cast<int>((t[2] + start) % n);
        const Face f{ids[i0], ids[i2], ids[i1]};  // against the loop
        for (int k = 0; k < 3; ++k) {
          const int a = (k == 0 ? i0 : k == 1 ? i1 : i2), b = (k == 0 ? i1 : k == 1 ? i2 : i0);
          const bool side = (a + 1) % static_cast<int>(n) == b || (b + 1) % static_cast<int>(n) == a;
          if (!side && edges_.contains(edge_key(ids[a], ids[b]))) fresh = false;
        }
        faces.push_back(f);
      }
      if (fresh) {
        out.insert(out.end(), faces.begin(), faces.end());
        return true;
      }
    }
    return false;
  }

  // The widest empty disk a random sample of the loop's local density may leave anywhere on the scan:
  // among N points of surface density ρ a disk of radius r is empty with probability e^(−πr²ρ), and
  // with πr²ρ = 2 ln N no such void is expected among about N places but once in N scans. ρ is measured at the loop's vertices (k = 25 raw
  // neighbours), which a real opening's rim sees on one side only: ρ comes out low there, the void large,
  // so the rule leans toward closing; an opening stays open when it is wider than twice this. The
  // sparser quarter's ρ, not the median's: a loop across a crease between a face every view saw and one
  // a single view grazed has most of its vertices by the dense face, and the voids to judge are the
  // sparse face's (the merged partial views' bore walls under the rim: 0.5 mm voids at ρ 6 /mm²).
  double largest_void(const std::vector<int>& cycle) const {
    constexpr int k = 25;
    const auto n = static_cast<double>(raw_.rows());
    if (n <= k) return 0;
    std::vector<double> density;
    std::vector<int> ids;
    std::vector<double> squared;
    for (int v : cycle) {
      index_.nearest(at(v), k, ids, squared);
      if (ids.size() == static_cast<std::size_t>(k) && squared.back() > 0) density.push_back(k / (std::numbers::pi * squared.back()));
    }
    if (density.empty()) return 0;
    const std::size_t quartile = density.size() / 4;
    std::nth_element(density.begin(), density.begin() + static_cast<std::ptrdiff_t>(quartile), density.end());
    return std::sqrt(2 * std::log(n) / (std::numbers::pi * density[quartile]));
  }

  // The longest loop worth a patch: max_perimeter_bins·B where the scan is denser than a point per bin,
  // and as many of the widest gaps the support test accepts (max(1.5 B, r*)) where it is sparser: a face
  // one view grazed leaves voids that scale with its own spacing, not the bin's (the plate's back face in
  // the merged partial views, 6.4 points/mm² against 8.2 per B²: a tangle of voids 24 mm round, 4.5 mm
  // across, where 60 B is 21 mm). An opening is no more at risk: its patch still fails the support test.
  double short_loop_limit(const std::vector<int>& cycle) const {
    return options_.max_perimeter_bins * bin_ * std::max(1.0, largest_void(cycle) / (options_.max_gap_bins * bin_));
  }

  // How well the raw cloud lies along a patch: the fraction of its sample points (every ≈ B/2, corners
  // left out: they are mesh vertices) that have a raw point within reach, and the farthest any sample
  // is from the cloud (the radius of the largest gap the patch covers).
  struct Support {
    double backed = 1;
    double widest_gap_mm = 0;
  };

  Support support(const std::vector<Face>& faces) const {
    const double spacing = 0.5 * bin_, reach = options_.support_bins * bin_;
    std::size_t samples = 0, backed = 0;
    double widest = 0;
    std::vector<int> ids;
    std::vector<double> squared;
    const auto probe = [&](const Vec3& x) {
      ++samples;
      index_.nearest(x, 1, ids, squared);
      const double d2 = squared.empty() ? 1e300 : squared.front();
      backed += d2 <= reach * reach;
      widest = std::max(widest, std::sqrt(d2));
    };
    for (const Face& f : faces) {
      const Vec3 t[3] = {at(f[0]), at(f[1]), at(f[2])};
      const double longest = std::max({(t[1] - t[0]).norm(), (t[2] - t[1]).norm(), (t[0] - t[2]).norm()});
      const int n = std::clamp(static_cast<int>(std::ceil(longest / spacing)), 1, 64);
      probe((t[0] + t[1] + t[2]) / 3);
      for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j) {
          const int k = n - i - j;
          if (i == n || j == n || k == n) continue;
          probe((i * t[0] + j * t[1] + k * t[2]) / n);
        }
    }
    return samples == 0 ? Support{} : Support{static_cast<double>(backed) / static_cast<double>(samples), widest};
  }

  // The patch closes the loop and nothing else: each loop side gets one facet (wound against it), each
  // new edge two of opposite winding, no edge of the mesh another. Whatever the construction, the mesh
  // stays edge-manifold and consistently oriented.
  bool closes_exactly(const std::vector<Face>& faces, const std::vector<int>& cycle) const {
    std::unordered_map<std::uint64_t, int> directed;
    for (const Face& f : faces)
      for (int k = 0; k < 3; ++k) {
        if (f[k] == f[(k + 1) % 3]) return false;
        const std::uint64_t key = directed_key(f[k], f[(k + 1) % 3]);
        if (++directed[key] > 1) return false;
      }
    std::unordered_set<std::uint64_t> sides;
    const std::size_t n = cycle.size();
    for (std::size_t i = 0; i < n; ++i) {
      const int a = cycle[i], b = cycle[(i + 1) % n];
      // The loop runs a → b in its facet; the patch must have b → a.
      if (!directed.contains(directed_key(b, a))) return false;
      sides.insert(edge_key(a, b));
    }
    for (const auto& [key, count] : directed) {
      const int from = static_cast<int>(key >> 32), to = static_cast<int>(key & 0xffffffffu);
      const std::uint64_t undirected = edge_key(from, to);
      if (sides.contains(undirected)) {
        if (directed.contains(directed_key(to, from))) return false;
        continue;
      }
      if (edges_.contains(undirected)) return false;
      if (!directed.contains(directed_key(to, from))) return false;
    }
    return true;
  }

  bool commit(const std::vector<Face>& faces, const std::vector<Vec3>& points, const std::vector<int>& cycle,
              double perimeter, const char* how) {
    if (!closes_exactly(faces, cycle)) {
      say(cycle, perimeter, "patch would not close the loop exactly", 0);
      failed_.push_back(cycle);
      return false;
    }
    // The new points sit at ids after those already added.
    const std::size_t before = extra_.size();
    extra_.insert(extra_.end(), points.begin(), points.end());
    // Backed nearly everywhere, or a gap no wider than the scan's own sampling voids (a random scan
    // leaves empty disks of about B; a real opening is empty across its whole width).
    const Support backing = support(faces);
    const bool backed = backing.backed >= options_.min_support ||
                        backing.widest_gap_mm <= std::max(options_.max_gap_bins * bin_, largest_void(cycle));
    say(cycle, perimeter, backed ? how : "unsupported", backing.backed);
    if (!backed) {
      extra_.resize(before);
      return false;
    }
    for (const Face& f : faces) {
      faces_.push_back(f);
      for (int k = 0; k < 3; ++k) edges_.insert(edge_key(f[k], f[(k + 1) % 3]));
    }
    return true;
  }

  bool fill(const std::vector<int>& cycle, double perimeter) {
    std::vector<Vec3> x;
    for (int i : cycle) x.push_back(at(i));
    const std::size_t n = cycle.size();
    // The faces around the loop: one group of normals, or two a crease apart.
    Vec3 seeds[2] = {normals_[cycle[0]], normals_[cycle[0]]};
    double worst = 2;
    for (int i : cycle)
      if (normals_[i].dot(seeds[0]) < worst) worst = normals_[i].dot(seeds[0]), seeds[1] = normals_[i];
    std::vector<int> group(n, 0);
    for (int round = 0; round < 5; ++round) {
      Vec3 sums[2] = {Vec3::Zero(), Vec3::Zero()};
      for (std::size_t i = 0; i < n; ++i) {
        group[i] = normals_[cycle[i]].dot(seeds[1]) > normals_[cycle[i]].dot(seeds[0]) ? 1 : 0;
        sums[group[i]] += normals_[cycle[i]];
      }
      for (int k = 0; k < 2; ++k)
        if (sums[k].norm() > 0) seeds[k] = sums[k].normalized();
    }
    const bool bent = seeds[0].dot(seeds[1]) < std::cos(options_.crease_angle_deg * std::numbers::pi / 180) &&
                      std::count(group.begin(), group.end(), 0) >= 2 && std::count(group.begin(), group.end(), 1) >= 2;
    if (bent && fill_bent(cycle, x, seeds, perimeter)) return true;
    Vec3 newell = Vec3::Zero(), centre = Vec3::Zero();
    for (std::size_t i = 0; i < n; ++i) newell += x[i].cross(x[(i + 1) % n]), centre += x[i] / static_cast<double>(n);
    // A flat patch only where the loop is flat: across a crease it would chamfer the edge.
    double off_plane = 0;
    if (newell.norm() > 0)
      for (const Vec3& p : x) off_plane = std::max(off_plane, std::abs((p - centre).dot(newell.normalized())));
    std::vector<Face> faces;
    if (newell.norm() > 0 && off_plane <= options_.flatness_bins * bin_ + 3 * options_.noise_sigma_mm && clip(cycle, newell.normalized(), x, faces))
      return commit(faces, {}, cycle, perimeter, "filled flat");
    // Curved, or across a crease the two-plane fill could not split: on the raw surface, if it is there.
    if (fill_curved(cycle, x, perimeter)) return true;
    // A loop folded or tangled by the noise (a ragged strip beside a crease): no plane sees it simple.
    if (fill_least_folding(cycle, x, perimeter)) return true;
    say(cycle, perimeter, bent ? "across a crease, not filled" : "not flat, an outline, not simple or no fresh diagonal", 0);
    failed_.push_back(cycle);
    return false;
  }

  // Where the raw surface crosses the line through p along n: the median offset of the raw points
  // within B of that line (p itself when none are).
  Vec3 onto_raw(const Vec3& p, const Vec3& n, double reach) const {
    std::vector<double> along;
    const std::vector<int> near = index_.within(p, reach);
    // Nearest the line first: on a curved surface the points farther off it lie toward its concave side.
    for (double width : {0.5 * bin_, bin_}) {
      for (int id : near) {
        const Vec3 d = raw_.row(id).transpose() - p;
        const double t = d.dot(n);
        if ((d - t * n).norm() <= width) along.push_back(t);
      }
      if (along.size() >= 3) break;
      along.clear();
    }
    if (along.empty()) return p;
    std::nth_element(along.begin(), along.begin() + static_cast<std::ptrdiff_t>(along.size() / 2), along.end());
    return p + along[along.size() / 2] * n;
  }

  // Ids of new patch vertices: after the mesh's and those patches already added.
  int patch_base() const { return old_vertices_ + static_cast<int>(extra_.size()); }
  Vec3 patch_position(int id, const std::vector<Vec3>& points) const {
    return id >= patch_base() ? points[static_cast<std::size_t>(id - patch_base())] : at(id);
  }

  // A fan from `apex` (a new vertex, appended to points) where the loop is a star around it in the plane
  // `flat` maps it to (every side turns the same way about the apex, once round).
  template <class Flat>
  bool fan(const std::vector<int>& cycle, const std::vector<Vec3>& x, const Vec3& apex, Flat&& flat,
           std::vector<Face>& faces, std::vector<Vec3>& points) const {
    const std::size_t n = cycle.size();
    const Eigen::Vector2d centre = flat(apex);
    double turn = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d a = flat(x[i]) - centre, b = flat(x[(i + 1) % n]) - centre;
      const double step = std::atan2(cross2(a, b), a.dot(b));
      if (turn != 0 && (step > 0) != (turn > 0)) return false;
      turn += step;
    }
    if (std::abs(std::abs(turn) - 2 * std::numbers::pi) > 0.1) return false;
    const int id = patch_base() + static_cast<int>(points.size());
    points.push_back(apex);
    for (std::size_t i = 0; i < n; ++i) faces.push_back({id, cycle[(i + 1) % n], cycle[i]});  // against the loop
    return true;
  }

  // Longest-edge bisection down to the growth's own edge (√6 B), both facets of a halved edge at once so
  // the patch stays conforming, each new vertex placed by `place`; the loop's own sides stay whole (the
  // facets beside them are the mesh's). False when the patch would outgrow kMaxPatchFaces.
  template <class Place>
  bool refine(const std::vector<int>& cycle, std::vector<Face>& faces, std::vector<Vec3>& points, Place&& place) const {
    std::unordered_set<std::uint64_t> sides;
    for (std::size_t i = 0; i < cycle.size(); ++i) sides.insert(edge_key(cycle[i], cycle[(i + 1) % cycle.size()]));
    const double longest = kMaxEdgeBins * bin_;
    while (true) {
      int a = -1, b = -1;
      double worst = longest;
      for (const Face& f : faces)
        for (int k = 0; k < 3; ++k) {
          const int u = f[k], v = f[(k + 1) % 3];
          const double length = (patch_position(u, points) - patch_position(v, points)).norm();
          if (length > worst && !sides.contains(edge_key(u, v))) worst = length, a = u, b = v;
        }
      if (a < 0) return true;
      if (faces.size() > kMaxPatchFaces) return false;
      points.push_back(place(0.5 * (patch_position(a, points) + patch_position(b, points))));
      const int m = patch_base() + static_cast<int>(points.size()) - 1;
      std::vector<Face> next;
      for (const Face& f : faces) {
        int k = 0;
        while (k < 3 && !((f[k] == a && f[(k + 1) % 3] == b) || (f[k] == b && f[(k + 1) % 3] == a))) ++k;
        if (k == 3) {
          next.push_back(f);
          continue;
        }
        const int u = f[k], v = f[(k + 1) % 3], w = f[(k + 2) % 3];
        next.push_back({u, m, w});
        next.push_back({m, v, w});
      }
      faces = std::move(next);
    }
  }

  // The largest angle between the normals of two patch facets sharing a side, or of a patch facet and
  // the rim facet across a loop side (`rim[i]` beside cycle[i] → cycle[i + 1]).
  double max_fold(const std::vector<Face>& faces, const std::vector<Vec3>& points, const std::vector<Vec3>& rim,
                  const std::vector<int>& cycle) const {
    // Each side's normal on the far side of it: the rim facet's along the loop, else the patch facet's.
    std::unordered_map<std::uint64_t, Vec3> beyond;
    for (std::size_t i = 0; i < cycle.size(); ++i) beyond.emplace(directed_key(cycle[i], cycle[(i + 1) % cycle.size()]), rim[i]);
    std::vector<Vec3> normals;
    for (const Face& f : faces) {
      const Vec3 p = patch_position(f[0], points), q = patch_position(f[1], points), r = patch_position(f[2], points);
      normals.push_back((q - p).cross(r - p).normalized());
      for (int k = 0; k < 3; ++k) beyond.emplace(directed_key(f[k], f[(k + 1) % 3]), normals.back());
    }
    double worst = 0;
    for (std::size_t i = 0; i < faces.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        const auto twin = beyond.find(directed_key(faces[i][(k + 1) % 3], faces[i][k]));
        if (twin != beyond.end()) worst = std::max(worst, std::acos(std::clamp(normals[i].dot(twin->second), -1.0, 1.0)));
      }
    return worst;
  }

  // No sliver: the growth's own smallest angle holds for a patch too.
  bool angles_above_minimum(const std::vector<Face>& faces, const std::vector<Vec3>& points) const {
    for (const Face& f : faces) {
      const Vec3 p[3] = {patch_position(f[0], points), patch_position(f[1], points), patch_position(f[2], points)};
      for (int k = 0; k < 3; ++k) {
        const Vec3 u = p[(k + 1) % 3] - p[k], w = p[(k + 2) % 3] - p[k];
        if (u.cross(w).norm() < std::sin(kMinPatchAngle) * u.norm() * w.norm()) return false;
      }
    }
    return true;
  }

  // A curved loop off any crease: a fan from a centre on the raw surface where the loop is a star around
  // it, else ear clipping seen along its normal, then refined with each new vertex put onto the raw
  // surface along the loop's normal: a flat patch over a curved loop would lie off it by its sagitta.
  bool fill_curved(const std::vector<int>& cycle, const std::vector<Vec3>& x, double perimeter) {
    const std::size_t n = cycle.size();
    Vec3 centre = Vec3::Zero(), normal = Vec3::Zero();
    for (std::size_t i = 0; i < n; ++i) centre += x[i] / static_cast<double>(n), normal += normals_[cycle[i]];
    if (!(normal.norm() > 0)) return false;
    normal.normalize();
    // As in clip: the surface lies left of a hole's loop; a patch over an outline would be a second sheet.
    Vec3 newell = Vec3::Zero();
    for (std::size_t i = 0; i < n; ++i) newell += x[i].cross(x[(i + 1) % n]);
    if (!(normal.dot(newell) < 0)) return false;
    double radius = 0;
    for (const Vec3& p : x) radius = std::max(radius, (p - centre).norm());
    const auto onto_surface = [&](const Vec3& p) { return onto_raw(p, normal, radius + bin_); };
    std::vector<Face> faces;
    std::vector<Vec3> points;
    const Vec3 t1 = normal.unitOrthogonal(), t2 = normal.cross(t1);
    const auto seen = [&](const Vec3& p) { return Eigen::Vector2d(p.dot(t1), p.dot(t2)); };
    if (!fan(cycle, x, onto_surface(centre), seen, faces, points)) {
      faces.clear(), points.clear();
      if (!clip(cycle, normal, x, faces)) return false;
    }
    if (!refine(cycle, faces, points, onto_surface) || !angles_above_minimum(faces, points)) return false;
    return commit(faces, points, cycle, perimeter, "filled curved");
  }

  // The least-folding triangulation of the loop's own vertices (Liepa's), refined with each new vertex
  // onto the raw surface along the patch's normal. A patch that folds back onto its rim, or faces
  // against it (an outline's: a second sheet over the surface), is refused.
  bool fill_least_folding(const std::vector<int>& cycle, const std::vector<Vec3>& x, double perimeter) {
    const std::size_t n = cycle.size();
    if (n > kMaxLeastFoldingLoop) return false;
    std::vector<Vec3> rim(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto side = rim_normals_.find(directed_key(cycle[i], cycle[(i + 1) % n]));
      if (side == rim_normals_.end() || !(side->second.norm() > 0)) return false;
      rim[i] = side->second;
    }
    const auto patch = least_folding_patch(x, rim, [&](int a, int b) {
      return !edges_.contains(edge_key(cycle[static_cast<std::size_t>(a)], cycle[static_cast<std::size_t>(b)]));
    });
    if (!patch) return false;
    std::vector<Face> faces;
    Vec3 normal = Vec3::Zero();
    for (const auto& t : patch->triangles) {
      faces.push_back({cycle[static_cast<std::size_t>(t[0])], cycle[static_cast<std::size_t>(t[1])], cycle[static_cast<std::size_t>(t[2])]});
      const Vec3& a = x[static_cast<std::size_t>(t[0])];
      normal += (x[static_cast<std::size_t>(t[1])] - a).cross(x[static_cast<std::size_t>(t[2])] - a);
    }
    if (!(normal.norm() > 0)) return false;
    normal.normalize();
    // A hole's patch faces the way its rim does (across a right-angled crease, half of it); an outline's
    // (a second sheet over the surface) faces against it.
    double facing = 0;
    for (const Vec3& r : rim) facing += r.dot(normal) / static_cast<double>(n);
    if (patch->max_dihedral_rad > kMaxPatchFold || facing < kMinPatchFacing) {
      say(cycle, perimeter, "least folding patch folds or faces away (deg)", patch->max_dihedral_rad * 180 / std::numbers::pi);
      return false;
    }
    // Each facet lies in one of the faces the loop joins or between them, so it faces within 60° of some
    // rim facet; one that faces away from all of them is a flap folded under a crease (on the plate's top
    // front edge of a random scan at σ ε/2, facets facing down on the top: "too few faces" on the edge).
    // Refused while the loop will be cut back and tried wider; otherwise a flap is better than a pinhole.
    double worst_facet = 1;
    for (const auto& t : patch->triangles) {
      const Vec3& a = x[static_cast<std::size_t>(t[0])];
      const Vec3 facet = (x[static_cast<std::size_t>(t[1])] - a).cross(x[static_cast<std::size_t>(t[2])] - a);
      if (!(facet.norm() > 0)) continue;
      double best = -1;
      for (const Vec3& r : rim) best = std::max(best, r.dot(facet.normalized()));
      worst_facet = std::min(worst_facet, best);
    }
    if (worst_facet < kMinFacetFacing && !last_round_ && recut(x, perimeter, index_, options_)) {
      say(cycle, perimeter, "least folding patch has a facet facing away from its rim (cos)", worst_facet);
      return false;
    }
    std::vector<Vec3> points;
    // Beside a crease the line along the patch's normal meets the other face too: a vertex moves at most
    // B/2, else stays put (a far move would lengthen the edges it was to shorten).
    const auto place = [&](const Vec3& p) {
      const Vec3 q = onto_raw(p, normal, bin_);
      return (q - p).norm() <= 0.5 * bin_ ? q : p;
    };
    const std::vector<Face> unrefined = faces;
    if (!refine(cycle, faces, points, place)) {
      say(cycle, perimeter, "least folding patch too big", static_cast<double>(faces.size()));
      return false;
    }
    // Across a rim the line along the patch's normal may meet the face beyond the crease outside the
    // loop, and a vertex put there folds the patch over (the grid scan's rims at 45° to its rows: facets
    // facing down on the plate's top, read as concave edge points). Then the new vertices stay on their
    // chords, where the patch folds no more than its least-folding triangulation does.
    if (max_fold(faces, points, rim, cycle) > patch->max_dihedral_rad + kPatchRefineFold) {
      faces = unrefined, points.clear();
      refine(cycle, faces, points, [](const Vec3& p) { return p; });
    }
    return commit(faces, points, cycle, perimeter, "filled least folding");
  }

  // A strip no wider than kMaxStripWidthBins·B: most of its vertices have a vertex of the other run that
  // close, one farther along the loop than a short loop goes round (on a circle of radius R ≫ B the
  // nearest vertex that far along is about that far away).
  bool thin_strip(const std::vector<int>& cycle) const {
    const std::size_t n = cycle.size();
    if (n > kMaxStripVertices) return false;  // the width is measured in O(n²)
    std::vector<double> along(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i) along[i + 1] = along[i] + (at(cycle[(i + 1) % n]) - at(cycle[i])).norm();
    const double perimeter = along[n], apart = kStripApartBins * bin_;
    std::vector<double> width;
    for (std::size_t i = 0; i < n; ++i) {
      double nearest = INFINITY;
      for (std::size_t j = 0; j < n; ++j) {
        const double arc = std::abs(along[i] - along[j]);
        if (std::min(arc, perimeter - arc) > apart) nearest = std::min(nearest, (at(cycle[i]) - at(cycle[j])).norm());
      }
      width.push_back(nearest);
    }
    std::nth_element(width.begin(), width.begin() + static_cast<std::ptrdiff_t>(n / 2), width.end());
    return width[n / 2] <= kMaxStripWidthBins * bin_;
  }

  // A thin strip cut by rungs (diagonals no longer than kMaxRungBins·B between its runs) into pieces of at most
  // kMaxStripPiece vertices, each given its least-folding patch; a rung borders two pieces and no facet
  // yet, so it turns nothing in either.
  bool fill_strip(const std::vector<int>& cycle, double perimeter) {
    const std::size_t n = cycle.size();
    std::vector<std::vector<std::size_t>> pending(1), pieces;
    for (std::size_t i = 0; i < n; ++i) pending[0].push_back(i);
    while (!pending.empty()) {
      std::vector<std::size_t> piece = std::move(pending.back());
      pending.pop_back();
      if (piece.size() <= kMaxStripPiece) {
        pieces.push_back(std::move(piece));
        continue;
      }
      const std::size_t m = piece.size();
      std::size_t best_i = 0, best_j = 0;
      double best = INFINITY;
      for (std::size_t i = 0; i < m; i += std::max<std::size_t>(1, m / 16))
        for (std::size_t step = m / 4; step <= 3 * m / 4; ++step) {
          const std::size_t j = (i + step) % m;
          const double d = (at(cycle[piece[i]]) - at(cycle[piece[j]])).norm();
          if (d < best && !edges_.contains(edge_key(cycle[piece[i]], cycle[piece[j]]))) best = d, best_i = i, best_j = j;
        }
      if (!(best <= kMaxRungBins * bin_)) {
        say(cycle, perimeter, "strip without a short rung", best);
        return false;
      }
      std::vector<std::size_t> first, second;
      for (std::size_t k = best_i;; k = (k + 1) % m) {
        first.push_back(piece[k]);
        if (k == best_j) break;
      }
      for (std::size_t k = best_j;; k = (k + 1) % m) {
        second.push_back(piece[k]);
        if (k == best_i) break;
      }
      pending.push_back(std::move(first));
      pending.push_back(std::move(second));
    }
    std::vector<Face> faces;
    for (const std::vector<std::size_t>& piece : pieces) {
      const std::size_t m = piece.size();
      std::vector<Vec3> x, rim;
      for (std::size_t k = 0; k < m; ++k) {
        x.push_back(at(cycle[piece[k]]));
        const bool side = piece[(k + 1) % m] == (piece[k] + 1) % n;
        const auto found = side ? rim_normals_.find(directed_key(cycle[piece[k]], cycle[piece[(k + 1) % m]])) : rim_normals_.end();
        rim.push_back(found == rim_normals_.end() ? Vec3::Zero() : found->second);
      }
      const auto patch = least_folding_patch(x, rim, [&](int a, int b) {
        return !edges_.contains(edge_key(cycle[piece[static_cast<std::size_t>(a)]], cycle[piece[static_cast<std::size_t>(b)]]));
      });
      if (!patch || patch->max_dihedral_rad > kMaxPatchFold) {
        say(cycle, perimeter, "strip piece folds (deg)", patch ? patch->max_dihedral_rad * 180 / std::numbers::pi : 999);
        return false;
      }
      Vec3 normal = Vec3::Zero();
      for (const auto& t : patch->triangles) {
        const Vec3& a = x[static_cast<std::size_t>(t[0])];
        normal += (x[static_cast<std::size_t>(t[1])] - a).cross(x[static_cast<std::size_t>(t[2])] - a);
        faces.push_back({cycle[piece[static_cast<std::size_t>(t[0])]], cycle[piece[static_cast<std::size_t>(t[1])]],
                         cycle[piece[static_cast<std::size_t>(t[2])]]});
      }
      double facing = 0, sides = 0;
      for (const Vec3& r : rim)
        if (!r.isZero()) facing += r.dot(normal.normalized()), ++sides;
      if (!(sides > 0) || facing / sides < kMinPatchFacing) {
        say(cycle, perimeter, "strip piece faces away", facing / std::max(sides, 1.0));
        return false;
      }
    }
    std::vector<Vec3> points;
    if (!refine(cycle, faces, points, [](const Vec3& p) { return p; })) {
      say(cycle, perimeter, "strip patch too big", static_cast<double>(faces.size()));
      return false;
    }
    return commit(faces, points, cycle, perimeter, "filled as a strip");
  }

  // Where the two faces' runs cannot be clipped apart (a loop that wiggles across the crease, sides
  // that are no single runs): a fan from the crease line's point nearest the loop's centre, which lies on
  // both planes, so each facet whose loop side lies on one face lies in that face's plane and the edge
  // stays sharp; halved longest edge first down to √6 B, each new vertex onto the nearer plane.
  bool crease_fan(const std::vector<int>& cycle, const std::vector<Vec3>& x, const Vec3 (&normal)[2], const double (&offset)[2],
                  double perimeter) {
    const std::size_t n = cycle.size();
    const double c = normal[0].dot(normal[1]), det = 1 - c * c;
    if (det < 1e-6) return false;
    Vec3 centre = Vec3::Zero();
    for (const Vec3& p : x) centre += p / static_cast<double>(n);
    const double r0 = offset[0] - normal[0].dot(centre), r1 = offset[1] - normal[1].dot(centre);
    const Vec3 apex = centre + (r0 - c * r1) / det * normal[0] + (r1 - c * r0) / det * normal[1];
    if ((apex - centre).norm() > 0.5 * perimeter / std::numbers::pi + bin_) return false;  // the line misses the loop
    const auto onto_faces = [&](const Vec3& p) {
      const double d0 = normal[0].dot(p) - offset[0], d1 = normal[1].dot(p) - offset[1];
      return Vec3(std::abs(d0) <= std::abs(d1) ? p - d0 * normal[0] : p - d1 * normal[1]);
    };
    // The two faces unfolded about the crease line into one plane: (along the line, across it), face 0
    // on the positive side. A loop that wiggles across the crease stays a star there.
    const Vec3 along = normal[0].cross(normal[1]).normalized();
    Vec3 into[2] = {along.cross(normal[0]), along.cross(normal[1])};
    for (int k = 0; k < 2; ++k) {
      double sum = 0;
      for (const Vec3& p : x) {
        const double d0 = std::abs(normal[0].dot(p) - offset[0]), d1 = std::abs(normal[1].dot(p) - offset[1]);
        if ((k == 0) == (d0 <= d1)) sum += (p - apex).dot(into[k]);
      }
      if (sum < 0) into[k] = -into[k];
    }
    const auto unfolded = [&](const Vec3& p) {
      const Vec3 d = p - apex;
      const bool first = std::abs(normal[0].dot(p) - offset[0]) <= std::abs(normal[1].dot(p) - offset[1]);
      return Eigen::Vector2d(d.dot(along), first ? d.dot(into[0]) : -d.dot(into[1]));
    };
    std::vector<Face> faces;
    std::vector<Vec3> points;
    if (!fan(cycle, x, apex, unfolded, faces, points) || !refine(cycle, faces, points, onto_faces) ||
        !angles_above_minimum(faces, points))
      return false;
    return commit(faces, points, cycle, perimeter, "filled by a fan from the crease");
  }

  // Two faces: each side's vertices by the nearer plane, which must take one run of the loop each; the
  // crease line joins the two crossings through new vertices every ≤ B, and each side is clipped in its plane.
  bool fill_bent(const std::vector<int>& cycle, const std::vector<Vec3>& x, const Vec3 (&seed)[2], double perimeter) {
    const std::size_t n = cycle.size();
    std::vector<int> side(n);
    Vec3 normal[2];
    double offset[2];
    for (int round = 0; round < 2; ++round) {
      for (int k = 0; k < 2; ++k) {
        normal[k] = round == 0 ? seed[k] : normal[k];
        std::vector<double> d;
        for (std::size_t i = 0; i < n; ++i)
          if (round == 0 ? normals_[cycle[i]].dot(seed[k]) >= normals_[cycle[i]].dot(seed[1 - k]) : side[i] == k)
            d.push_back(normal[k].dot(x[i]));
        if (d.empty()) return false;
        std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
        offset[k] = d[d.size() / 2];
      }
      for (std::size_t i = 0; i < n; ++i)
        side[i] = std::abs(normal[1].dot(x[i]) - offset[1]) < std::abs(normal[0].dot(x[i]) - offset[0]) ? 1 : 0;
    }
    {
      // A vertex on both planes (at the crease, within the noise) takes the side of the run it follows.
      std::vector<char> either(n, 0);
      for (std::size_t i = 0; i < n; ++i)
        either[i] = std::abs(normal[0].dot(x[i]) - offset[0]) < 0.3 * bin_ && std::abs(normal[1].dot(x[i]) - offset[1]) < 0.3 * bin_;
      std::size_t decided = n;
      for (std::size_t i = 0; i < n; ++i)
        if (!either[i]) decided = i;
      if (decided < n)
        for (std::size_t s = 1; s < n; ++s) {
          const std::size_t i = (decided + s) % n;
          if (either[i]) side[i] = side[(i + n - 1) % n];
        }
    }
    // The faces' planes from the raw points around the loop, each away from the other face: the mesh's
    // normals are noisy and blend the two faces, and the crease line must be where the scan says.
    {
      Vec3 centre = Vec3::Zero();
      for (const Vec3& p : x) centre += p / static_cast<double>(n);
      double radius = 0;
      for (const Vec3& p : x) radius = std::max(radius, (p - centre).norm());
      const std::vector<int> near = index_.within(centre, radius + bin_);
      for (int k = 0; k < 2; ++k) {
        std::vector<Vec3> on;
        for (int id : near) {
          const Vec3 p = raw_.row(id).transpose();
          if (std::abs(normal[k].dot(p) - offset[k]) < 0.25 * bin_ && std::abs(normal[1 - k].dot(p) - offset[1 - k]) > 0.5 * bin_)
            on.push_back(p);
        }
        if (on.size() < 10) continue;
        Vec3 mean = Vec3::Zero();
        for (const Vec3& p : on) mean += p / static_cast<double>(on.size());
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (const Vec3& p : on) cov += (p - mean) * (p - mean).transpose();
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
        if (!(eig.eigenvalues()(1) > 4 * eig.eigenvalues()(0))) continue;  // not a plane patch
        Vec3 fitted = eig.eigenvectors().col(0).normalized();
        if (fitted.dot(normal[k]) < 0) fitted = -fitted;
        if (fitted.dot(normal[k]) < std::cos(0.35)) continue;  // not the face the loop's facets saw
        normal[k] = fitted;
        offset[k] = fitted.dot(mean);
      }
    }
    // One run of each side around the loop.
    std::size_t switches = 0, first = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (side[i] != side[(i + n - 1) % n]) {
        ++switches;
        if (side[i] == 0) first = i;
      }
    if (switches != 2) return crease_fan(cycle, x, normal, offset, perimeter);
    std::vector<int> run[2];
    std::vector<Vec3> run_x[2];
    for (std::size_t s = 0; s < n; ++s) {
      const std::size_t i = (first + s) % n;
      run[side[i]].push_back(cycle[i]);
      run_x[side[i]].push_back(x[i]);
    }
    // A lone vertex off the face is noise, not a side.
    if (run[0].size() < 2 || run[1].size() < 2) return crease_fan(cycle, x, normal, offset, perimeter);
    const double c = normal[0].dot(normal[1]), det = 1 - c * c;
    if (det < 1e-6) return false;
    const auto on_line = [&](const Vec3& p) {  // the point of the crease line nearest p
      const double r0 = offset[0] - normal[0].dot(p), r1 = offset[1] - normal[1].dot(p);
      return Vec3(p + (r0 - c * r1) / det * normal[0] + (r1 - c * r0) / det * normal[1]);
    };
    // Crossing 1: from the side-0 run's end to the side-1 run's start; crossing 2: back.
    const auto crossing = [&](int a, const Vec3& xa, int b, const Vec3& xb, std::vector<Vec3>& points, bool& is_new) {
      const Vec3 pa = on_line(xa), pb = on_line(xb);
      if ((pa - xa).norm() < 0.25 * bin_) return is_new = false, a;
      if ((pb - xb).norm() < 0.25 * bin_) return is_new = false, b;
      points.push_back(on_line(0.5 * (xa + xb)));
      is_new = true;
      return -1;
    };
    std::vector<Vec3> points;
    bool new1 = false, new2 = false;
    int x1 = crossing(run[0].back(), run_x[0].back(), run[1].front(), run_x[1].front(), points, new1);
    const Vec3 p1 = new1 ? points.back() : at(x1);
    int x2 = crossing(run[1].back(), run_x[1].back(), run[0].front(), run_x[0].front(), points, new2);
    const Vec3 p2 = new2 ? points.back() : at(x2);
    const int base = old_vertices_ + static_cast<int>(extra_.size());
    if (new1) x1 = base;
    if (new2) x2 = base + (new1 ? 1 : 0);
    if (x1 == x2) return false;
    // Interior chain points from p1 to p2, on the line.
    const double length = (p2 - p1).norm();
    if (length > 0.5 * options_.max_perimeter_bins * bin_) return false;
    const int segments = std::max(1, static_cast<int>(std::ceil(length / bin_)));
    std::vector<int> chain{x1};
    std::vector<Vec3> chain_x{p1};
    for (int k = 1; k < segments; ++k) {
      const Vec3 p = on_line(p1 + (p2 - p1) * (static_cast<double>(k) / segments));
      chain.push_back(base + static_cast<int>(points.size()));
      chain_x.push_back(p);
      points.push_back(p);
    }
    chain.push_back(x2);
    chain_x.push_back(p2);
    if (chain.size() == 2 && edges_.contains(edge_key(x1, x2))) return false;
    // Side 0: its run, then the chain x1 → x2; side 1: its run, then the chain back.
    std::vector<int> poly[2];
    std::vector<Vec3> poly_x[2];
    for (int k = 0; k < 2; ++k) {
      poly[k] = run[k];
      poly_x[k] = run_x[k];
      std::vector<int> ch = chain;
      std::vector<Vec3> ch_x = chain_x;
      if (k == 1) std::reverse(ch.begin(), ch.end()), std::reverse(ch_x.begin(), ch_x.end());
      for (std::size_t i = 0; i < ch.size(); ++i) {
        if (std::find(poly[k].begin(), poly[k].end(), ch[i]) != poly[k].end()) continue;  // a run's own end on the line
        poly[k].push_back(ch[i]);
        poly_x[k].push_back(ch_x[i]);
      }
      if (poly[k].size() < 3) return false;
    }
    std::vector<Face> faces;
    if (!clip(poly[0], normal[0], poly_x[0], faces) || !clip(poly[1], normal[1], poly_x[1], faces))
      return crease_fan(cycle, x, normal, offset, perimeter);
    // A new crossing point lies off the loop side it stands for: that side's twin is a facet to it.
    if (new1) faces.push_back({run[1].front(), run[0].back(), x1});
    if (new2) faces.push_back({run[0].front(), run[1].back(), x2});
    return commit(faces, points, cycle, perimeter, "filled across a crease");
  }

 public:
  std::vector<std::vector<int>> failed_;  // loops no patch could close: their ragged rims are cut back

 private:
  TriangleMesh& mesh_;
  const Points& raw_;
  const CloudIndex& index_;
  const HoleFillingOptions& options_;
  double bin_;
  int old_vertices_;
  bool last_round_ = false;
  bool dump_ = false;
  std::unordered_set<std::uint64_t> edges_;
  std::unordered_map<std::uint64_t, Vec3> rim_normals_;  // by the loop side's directed key
  std::vector<Vec3> normals_;
  std::vector<std::vector<int>> loops_;
  std::vector<Face> faces_;
  std::vector<Vec3> extra_;
};

}  // namespace

HoleFilling fill_false_holes(TriangleMesh& mesh, const Points& raw, const CloudIndex& raw_index,
                             const HoleFillingOptions& options) {
  HoleFilling out;
  if (mesh.faces.rows() == 0 || raw.rows() == 0 || !(options.bin_mm > 0) || !std::isfinite(options.bin_mm)) return out;
  // Rounds past options.rounds recut only the small failed loops: a pinhole of a few facets whose rim
  // folds (no fresh diagonal, a slit) is no crease to misplace.
  const int rounds = options.rounds + options.small_loop_rounds;
  for (int round = 0; round < rounds; ++round) {
    Filler filler(mesh, raw, raw_index, options, round + 1 >= rounds);
    const HoleFilling r = filler.run();
    out.loops_examined += r.loops_examined;
    out.loops_filled += r.loops_filled;
    out.faces_added += r.faces_added;
    out.vertices_added += r.vertices_added;
    std::vector<std::vector<int>> cut;
    for (const auto& cycle : filler.failed_) {
      double perimeter = 0;
      std::vector<Vec3> loop;
      for (std::size_t i = 0; i < cycle.size(); ++i) {
        perimeter += (vertex(mesh, cycle[(i + 1) % cycle.size()]) - vertex(mesh, cycle[i])).norm();
        loop.push_back(vertex(mesh, cycle[i]));
      }
      if (round + 1 < options.rounds || recut(loop, perimeter, raw_index, options)) cut.push_back(cycle);
    }
    if (cut.empty() || round + 1 >= rounds) break;
    // A loop no patch closes has a ragged rim (facets folded by the noise, a sliver fan): its vertices'
    // facets go, and the next round fills the wider, cleaner loop. Their vertices may be left unused.
    std::unordered_set<int> rim;
    for (const auto& cycle : cut) rim.insert(cycle.begin(), cycle.end());
    Triangles kept(mesh.faces.rows(), 3);
    Eigen::Index count = 0;
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
      if (!rim.contains(mesh.faces(f, 0)) && !rim.contains(mesh.faces(f, 1)) && !rim.contains(mesh.faces(f, 2)))
        kept.row(count++) = mesh.faces.row(f);
    out.faces_removed += static_cast<std::size_t>(mesh.faces.rows() - count);
    kept.conservativeResize(count, 3);
    mesh.faces = std::move(kept);
  }
  return out;
}

}  // namespace cmm::geometry
