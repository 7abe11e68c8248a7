// triangulate_scan: creases first (crease_points), the thinned points in their band dropped and the
// crease points added as vertices on both faces, each vertex told the surface it lies on, then the
// advancing front, the false holes it left filled (hole_filling), then each component turned outward
// and the mesh compacted and reported.
#include "geometry/region_growing.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "geometry/advancing_front.hpp"
#include "geometry/crease_points.hpp"
#include "geometry/edge_adjacency.hpp"
#include "geometry/face_geometry.hpp"
#include "geometry/hole_filling.hpp"
#include "geometry/mesh_topology.hpp"
#include "geometry/point_grid.hpp"

namespace cmm::geometry {
namespace {

constexpr int kMinComponentFaces = 24;  // fewer is a speck beside the surface, not a piece of it

double deg(double d) { return d * std::numbers::pi / 180; }
Vec3 row(const Points& p, Eigen::Index i) { return p.row(i).transpose(); }

double segment_distance(const Vec3& x, const Vec3& p0, const Vec3& p1) {
  const Vec3 d = p1 - p0;
  const double len2 = d.squaredNorm();
  const double t = len2 > 0 ? std::clamp((x - p0).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (x - p0 - t * d).norm();
}

// How far a thinned point lies off the surface its raw neighbourhood fits (0 without fits).
std::vector<double> off_surface(const Points& thinned, bool have_fits, const std::vector<LocalSurface>& fits,
                                const CloudIndex& raw_index) {
  std::vector<double> d(static_cast<std::size_t>(thinned.rows()), 0.0);
  if (!have_fits) return d;
  std::vector<int> ids;
  std::vector<double> squared;
  for (Eigen::Index i = 0; i < thinned.rows(); ++i) {
    if (!thinned.row(i).allFinite()) continue;
    raw_index.nearest(row(thinned, i), 1, ids, squared);
    if (!ids.empty()) d[i] = std::abs((row(thinned, i) - fits[ids[0]].origin).dot(fits[ids[0]].normal));
  }
  return d;
}

// Which thinned points become vertices: not within B/2 of a crease (the crease points take their
// place, so no vertex sits in the chamfer), and not within min_spacing of a point kept before them.
// A noisy surface leaves two points in bins stacked across it; the one nearer the fitted surface is
// kept first.
std::vector<int> kept_points(const Points& thinned, const std::vector<double>& off, const Creases& creases, double bin,
                             const std::vector<double>& min_spacing) {
  const Eigen::Index n = thinned.rows();
  std::vector<char> keep(static_cast<std::size_t>(n), 0);
  std::vector<int> order;
  for (Eigen::Index i = 0; i < n; ++i)
    if (thinned.row(i).allFinite()) order.push_back(static_cast<int>(i));
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return off[a] < off[b]; });
  const PointGrid grid(thinned, bin);
  for (int i : order) {
    bool crowded = false;
    grid.for_each_within(row(thinned, i), min_spacing[static_cast<std::size_t>(i)], [&](int j, double) { crowded |= keep[j] != 0; });
    keep[i] = !crowded;
  }
  const auto drop_near = [&](const Vec3& p0, const Vec3& p1) {
    grid.for_each_within(0.5 * (p0 + p1), 0.5 * (p1 - p0).norm() + 0.5 * bin, [&](int j, double) {
      if (segment_distance(row(thinned, j), p0, p1) < 0.5 * bin) keep[j] = 0;
    });
  };
  for (std::size_t k = 0; k < creases.corners; ++k) drop_near(creases.points[k].position, creases.points[k].position);
  for (const CreasePolyline& line : creases.polylines) {
    const std::size_t m = line.points.size();
    for (std::size_t i = 0; i + (line.closed ? 0 : 1) < m; ++i)
      drop_near(creases.points[line.points[i]].position, creases.points[line.points[(i + 1) % m]].position);
  }
  std::vector<int> kept;
  for (Eigen::Index i = 0; i < n; ++i)
    if (keep[i]) kept.push_back(static_cast<int>(i));
  return kept;
}

// A crease's facets must agree with their face better than they agree with the other one.
double crease_cos_tolerance(const CreasePoint& p, double crease_angle) {
  double turn = std::numbers::pi / 2;
  for (int i = 0; i < p.sides; ++i)
    for (int j = i + 1; j < p.sides; ++j) turn = std::min(turn, std::acos(std::min(1.0, std::abs(p.normals[i].dot(p.normals[j])))));
  return std::cos(std::min(crease_angle, 0.45 * turn));
}

struct Vertices {
  Points x;
  std::vector<int> thinned_index;  // −1: crease point
  std::vector<VertexSurface> surfaces;
  std::vector<int> nearest_raw;  // −1: crease point
};

Vertices gather_vertices(const Points& thinned, const std::vector<int>& kept, const Creases& creases, const Points& raw,
                         const std::vector<LocalSurface>& fits, const CloudIndex& raw_index, double bin,
                         double crease_angle) {
  Vertices v;
  const std::size_t n = kept.size() + creases.points.size();
  v.x.resize(static_cast<Eigen::Index>(n), 3);
  v.surfaces.resize(n);
  Points crease_x(static_cast<Eigen::Index>(creases.points.size()), 3);
  for (std::size_t k = 0; k < creases.points.size(); ++k) crease_x.row(static_cast<Eigen::Index>(k)) = creases.points[k].position.transpose();
  const PointGrid crease_grid(crease_x, 3 * bin);
  const bool have_fits = raw.rows() > 0 && static_cast<Eigen::Index>(fits.size()) == raw.rows();
  const double smooth_cos = std::cos(crease_angle);
  std::vector<int> ids;
  std::vector<double> squared;
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const Vec3 x = row(thinned, kept[i]);
    v.x.row(static_cast<Eigen::Index>(i)) = x.transpose();
    v.thinned_index.push_back(kept[i]);
    VertexSurface& s = v.surfaces[i];
    s.cos_tolerance = smooth_cos;
    int nearest = -1;
    if (have_fits) {
      raw_index.nearest(x, 8, ids, squared);
      if (!ids.empty()) nearest = ids.front();
      for (int id : ids)
        if (fits[id].regular) {
          s.normals[0] = fits[id].normal;
          s.count = 1;
          break;
        }
      if (s.count == 0 && nearest >= 0) s.normals[0] = fits[nearest].normal, s.count = 1;
    }
    v.nearest_raw.push_back(nearest);
    // Beside a crease the point takes the normal of the face it lies on: its fit may have blended both.
    int closest = -1;
    double closest_d2 = 9 * bin * bin;
    crease_grid.for_each_within(x, 3 * bin, [&](int c, double d2) {
      if (d2 < closest_d2) closest_d2 = d2, closest = c;
    });
    if (closest >= 0) {
      const CreasePoint& c = creases.points[closest];
      int side = 0;
      for (int k = 1; k < c.sides; ++k)
        if (std::abs((x - c.position).dot(c.normals[k])) < std::abs((x - c.position).dot(c.normals[side]))) side = k;
      s.normals[0] = c.normals[side];
      s.count = 1;
      s.cos_tolerance = crease_cos_tolerance(c, crease_angle);
      // And onto that face's plane: beside a crease the fits straddle it and the point kept its raw,
      // noisy place, and the facets at the crease, which give the edge its side normals, would tilt
      // by σ/B (6° at σ 0.065 mm, B 0.58 mm).
      const double off = (x - c.position).dot(c.normals[side]);
      if (std::abs(off) < 0.5 * bin) v.x.row(static_cast<Eigen::Index>(i)) = (x - off * c.normals[side]).transpose();
    }
  }
  for (std::size_t k = 0; k < creases.points.size(); ++k) {
    const std::size_t i = kept.size() + k;
    v.x.row(static_cast<Eigen::Index>(i)) = creases.points[k].position.transpose();
    v.thinned_index.push_back(-1);
    v.nearest_raw.push_back(-1);
    v.surfaces[i] = {creases.points[k].normals, creases.points[k].sides, crease_cos_tolerance(creases.points[k], crease_angle),
                     k < creases.corners ? -2 : -1};
  }
  for (std::size_t l = 0; l < creases.polylines.size(); ++l)
    for (int p : creases.polylines[l].points)
      if (static_cast<std::size_t>(p) >= creases.corners) v.surfaces[kept.size() + p].crease = static_cast<int>(l);
  return v;
}

// A seed faces the scanner's side where the scan has normals; else away from the cloud's centroid,
// and where that is undecided (a point beside the centroid's plane: a flat plate), up (+z).
Vec3 outward(const Vec3& n, const Vec3& x, const Vec3& centroid) {
  const Vec3 r = x - centroid;
  if (std::abs(n.dot(r)) > 0.2 * r.norm()) return n.dot(r) >= 0 ? n : Vec3(-n);
  for (int axis : {2, 1, 0})
    if (std::abs(n(axis)) > 1e-3) return n(axis) > 0 ? n : Vec3(-n);
  return n;
}

std::vector<Vec3> seed_normals(const Vertices& v, const Points& raw_normals, const Points& raw) {
  const bool scanner = raw_normals.rows() == raw.rows() && raw.rows() > 0;
  const Vec3 centroid = v.x.rows() > 0 ? Vec3(v.x.colwise().mean().transpose()) : Vec3::Zero();
  std::vector<Vec3> out(static_cast<std::size_t>(v.x.rows()), Vec3::Zero());
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (v.thinned_index[i] < 0 || v.surfaces[i].count == 0) continue;
    const Vec3 n = v.surfaces[i].normals[0];
    if (scanner && v.nearest_raw[i] >= 0) {
      out[i] = n.dot(row(raw_normals, v.nearest_raw[i])) >= 0 ? n : Vec3(-n);
    } else {
      out[i] = outward(n, row(v.x, static_cast<Eigen::Index>(i)), centroid);
    }
  }
  return out;
}

// Whether the scanner's normals can orient each facet: neighbouring vertices on one face have normals
// that agree in sign (≥ 95 %). A cloud from a tool that fitted its normals without orienting them has
// about half of them flipped, and then only whole components are oriented.
bool normals_orient_facets(const Vertices& v, const std::vector<Vec3>& seeds, bool scanner, double bin) {
  if (!scanner) return false;
  const PointGrid grid(v.x, 2 * bin);
  std::size_t pairs = 0, agree = 0;
  for (Eigen::Index i = 0; i < v.x.rows(); ++i) {
    const Vec3& n = seeds[static_cast<std::size_t>(i)];
    if (n.squaredNorm() == 0) continue;
    int nearest = -1;
    double best = 1e300;
    grid.for_each_within(row(v.x, i), 2 * bin, [&](int j, double d2) {
      const Vec3& m = seeds[static_cast<std::size_t>(j)];
      if (j != i && d2 < best && std::abs(m.dot(n)) > 0.9) best = d2, nearest = j;
    });
    if (nearest < 0) continue;
    ++pairs;
    agree += seeds[static_cast<std::size_t>(nearest)].dot(n) > 0;
  }
  return pairs > 0 && 20 * agree >= 19 * pairs;
}

// A component of a few facets beside the surface (a view's sparse edge, a cluster of strays the outlier
// removal kept) is no part of it: its outline would be one more loop, and its raw points still back the
// patch that closes the gap it sat in. Its vertices are left unused. So is one smaller than a square 8
// bins on a side: a band of wall seen deep in an opening less than 3 B across (a Ø3 hole, a 2 mm slot at
// B 0.7 mm; 10–13 mm², 25–32 facets) that no crease joins to the rim a bin-B mesh cannot bend round.
void drop_specks(TriangleMesh& mesh, double bin) {
  if (mesh.faces.rows() == 0) return;
  const EdgeAdjacency adjacency = edge_adjacency(mesh);
  int count = 0;
  const std::vector<int> component = face_components(mesh, adjacency, &count);
  if (count < 2) return;
  std::vector<int> size(static_cast<std::size_t>(count), 0);
  std::vector<double> area(static_cast<std::size_t>(count), 0);
  const FaceGeometry faces = face_geometry(mesh);
  for (std::size_t f = 0; f < component.size(); ++f) {
    const auto c = static_cast<std::size_t>(component[f]);
    ++size[c];
    area[c] += faces.areas[f];
  }
  const double min_area = 64 * bin * bin;
  Triangles kept(mesh.faces.rows(), 3);
  Eigen::Index rows = 0;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const auto c = static_cast<std::size_t>(component[static_cast<std::size_t>(f)]);
    if (size[c] >= kMinComponentFaces && area[c] >= min_area) kept.row(rows++) = mesh.faces.row(f);
  }
  if (rows == 0) return;  // all specks: a tiny scan, keep what there is
  kept.conservativeResize(rows, 3);
  mesh.faces = std::move(kept);
}

// Each edge-connected component is turned as a whole: by the majority of its points' scanner
// normals, else outward from the centroid (a closed part: positive volume), else up.
void orient_components(TriangleMesh& mesh, const Vertices& v, const Points& raw_normals, const Points& raw) {
  if (mesh.faces.rows() == 0) return;
  const EdgeAdjacency adjacency = edge_adjacency(mesh);
  int count = 0;
  const std::vector<int> component = face_components(mesh, adjacency, &count);
  const bool scanner = raw_normals.rows() == raw.rows() && raw.rows() > 0;
  const Vec3 centroid = mesh.vertices.colwise().mean().transpose();
  std::vector<double> votes(count, 0), outward_sum(count, 0), area_sum(count, 0);
  std::vector<Vec3> normal_sum(count, Vec3::Zero());
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Vec3 a = vertex(mesh, mesh.faces(f, 0)), b = vertex(mesh, mesh.faces(f, 1)), c = vertex(mesh, mesh.faces(f, 2));
    const Vec3 n2 = (b - a).cross(c - a);  // twice the area along the normal
    const int k = component[f];
    outward_sum[k] += n2.dot((a + b + c) / 3 - centroid);
    area_sum[k] += n2.norm();
    normal_sum[k] += n2;
    if (!scanner) continue;
    for (int corner = 0; corner < 3; ++corner) {
      const int r = v.nearest_raw[mesh.faces(f, corner)];
      if (r >= 0) votes[k] += n2.dot(row(raw_normals, r)) >= 0 ? 1 : -1;
    }
  }
  const double size = (mesh.vertices.colwise().maxCoeff() - mesh.vertices.colwise().minCoeff()).norm();
  std::vector<char> flip(count, 0);
  for (int k = 0; k < count; ++k) {
    if (scanner && votes[k] != 0) {
      flip[k] = votes[k] < 0;
    } else if (std::abs(outward_sum[k]) > 1e-3 * area_sum[k] * size) {
      flip[k] = outward_sum[k] < 0;
    } else {
      for (int axis : {2, 1, 0})
        if (std::abs(normal_sum[k](axis)) > 1e-6 * area_sum[k]) {
          flip[k] = normal_sum[k](axis) < 0;
          break;
        }
    }
  }
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    if (flip[component[f]]) std::swap(mesh.faces(f, 1), mesh.faces(f, 2));
}

}  // namespace

Triangulation triangulate_scan(const Points& thinned, const Points& raw, const std::vector<LocalSurface>& raw_fits,
                               const CloudIndex& raw_index, const Points& raw_normals,
                               const RegionGrowingOptions& options) {
  Triangulation out;
  const double bin = options.bin_mm;
  if (!(bin > 0) || !std::isfinite(bin)) return out;
  if (!options.reach_mm.empty() && options.reach_mm.size() != static_cast<std::size_t>(thinned.rows()))
    throw std::invalid_argument("triangulate_scan: " + std::to_string(options.reach_mm.size()) + " reaches for " +
                                std::to_string(thinned.rows()) + " thinned points");
  Creases creases;
  if (raw.rows() > 0 && static_cast<Eigen::Index>(raw_fits.size()) == raw.rows())
    creases = find_creases(raw, raw_fits, raw_index, {bin, options.crease_angle_deg, 2, options.cancel});
  const bool have_fits = raw.rows() > 0 && static_cast<Eigen::Index>(raw_fits.size()) == raw.rows();
  // Adaptive bins: a point is crowded at half its own bin, not the coarsest one.
  std::vector<double> min_spacing(static_cast<std::size_t>(thinned.rows()), options.min_spacing_bins * bin);
  for (std::size_t i = 0; options.reach_from_bins && i < options.reach_mm.size() && i < min_spacing.size(); ++i)
    min_spacing[i] = options.min_spacing_bins * options.reach_mm[i] / options.max_edge_bins;
  const std::vector<int> kept = kept_points(thinned, off_surface(thinned, have_fits, raw_fits, raw_index), creases, bin, min_spacing);
  const Vertices v = gather_vertices(thinned, kept, creases, raw, raw_fits, raw_index, bin, deg(options.crease_angle_deg));

  std::vector<CreaseEdge> crease_edges;
  const int first_crease = static_cast<int>(kept.size());
  for (const CreasePolyline& line : creases.polylines) {
    const std::size_t m = line.points.size();
    for (std::size_t i = 0; i + (line.closed ? 0 : 1) < m; ++i) {
      const int a = line.points[i], b = line.points[(i + 1) % m];
      // The side normals of the polyline's own point (a corner has three).
      const CreasePoint& p = creases.points[creases.points[a].sides == 2 ? a : b];
      crease_edges.push_back({first_crease + a, first_crease + b, p.normals[0], p.normals[1],
                              crease_cos_tolerance(p, deg(options.crease_angle_deg))});
    }
  }
  std::vector<char> can_seed(static_cast<std::size_t>(v.x.rows()), 0);
  for (std::size_t i = 0; i < kept.size(); ++i) can_seed[i] = v.surfaces[i].count > 0;
  FrontOptions front{bin, options.min_angle_deg, options.fold_angle_deg, options.max_edge_bins, {}, options.cancel};
  front.larger_reach_joins = !options.reach_from_bins;
  if (!options.reach_mm.empty()) {
    front.reach_mm.assign(static_cast<std::size_t>(v.x.rows()), options.max_edge_bins * bin);
    for (std::size_t i = 0; i < kept.size(); ++i) front.reach_mm[i] = options.reach_mm[static_cast<std::size_t>(kept[i])];
  }
  const std::vector<Vec3> seeds = seed_normals(v, raw_normals, raw);
  front.seed_normals_oriented = normals_orient_facets(v, seeds, raw_normals.rows() == raw.rows() && raw.rows() > 0, bin);
  const FrontResult grown = grow_front(v.x, v.surfaces, seeds, can_seed, crease_edges, front);

  // Compact: only the vertices the facets use, thinned points first.
  std::vector<int> index(static_cast<std::size_t>(v.x.rows()), -1);
  for (Eigen::Index f = 0; f < grown.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) index[grown.faces(f, k)] = 0;
  int next = 0;
  for (int& i : index)
    if (i == 0) i = next++;
  out.mesh.vertices.resize(next, 3);
  for (std::size_t i = 0; i < index.size(); ++i) {
    if (index[i] < 0) continue;
    out.mesh.vertices.row(index[i]) = v.x.row(static_cast<Eigen::Index>(i));
    out.thinned_index.push_back(v.thinned_index[i]);
  }
  out.mesh.faces.resize(grown.faces.rows(), 3);
  for (Eigen::Index f = 0; f < grown.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) out.mesh.faces(f, k) = index[grown.faces(f, k)];
  // Adaptive bins grow to bin_mm on flat faces; a speck is judged by the finest (each point's reach is
  // max_edge_bins of its own bin).
  double finest_bin = bin;
  if (!options.reach_mm.empty()) finest_bin = std::min(bin, *std::min_element(options.reach_mm.begin(), options.reach_mm.end()) / options.max_edge_bins);
  drop_specks(out.mesh, finest_bin);
  // Gaps the front left where the noise kept every candidate from agreeing: raw points lie across them.
  if (raw.rows() > 0 && raw_index.size() == static_cast<std::size_t>(raw.rows())) {
    HoleFillingOptions filling;
    filling.bin_mm = bin;
    filling.crease_angle_deg = options.crease_angle_deg;
    filling.noise_sigma_mm = options.noise_sigma_mm;
    const HoleFilling filled = fill_false_holes(out.mesh, raw, raw_index, filling);
    out.holes_filled = filled.loops_filled;
    out.thinned_index.resize(out.thinned_index.size() + filled.vertices_added, -1);  // on a crease
    // Again: the filling cuts the rim facets of a ragged loop back, and a piece that hung on by them (a
    // wall fragment deep in the plate's slot, 4.6 mm² at B 0.32 mm) is left on its own.
    drop_specks(out.mesh, finest_bin);
  }
  Vertices compact;
  for (std::size_t i = 0; i < index.size(); ++i)
    if (index[i] >= 0) compact.nearest_raw.push_back(v.nearest_raw[i]);
  compact.nearest_raw.resize(static_cast<std::size_t>(out.mesh.vertices.rows()), -1);
  {
    // Compact again: the filling may have cut facets from around a ragged loop and left vertices unused.
    std::vector<int> again(static_cast<std::size_t>(out.mesh.vertices.rows()), -1);
    for (Eigen::Index f = 0; f < out.mesh.faces.rows(); ++f)
      for (int k = 0; k < 3; ++k) again[out.mesh.faces(f, k)] = 0;
    int used = 0;
    for (int& i : again)
      if (i == 0) i = used++;
    if (used < out.mesh.vertices.rows()) {
      Points x(used, 3);
      std::vector<int> thinned_index, nearest_raw;
      for (std::size_t i = 0; i < again.size(); ++i) {
        if (again[i] < 0) continue;
        x.row(again[i]) = out.mesh.vertices.row(static_cast<Eigen::Index>(i));
        thinned_index.push_back(out.thinned_index[i]);
        nearest_raw.push_back(compact.nearest_raw[i]);
      }
      for (Eigen::Index f = 0; f < out.mesh.faces.rows(); ++f)
        for (int k = 0; k < 3; ++k) out.mesh.faces(f, k) = again[out.mesh.faces(f, k)];
      for (int& i : index)
        if (i >= 0) i = again[i];
      out.mesh.vertices = std::move(x);
      out.thinned_index = std::move(thinned_index);
      compact.nearest_raw = std::move(nearest_raw);
    }
  }
  orient_components(out.mesh, compact, raw_normals, raw);

  for (const CreasePolyline& line : creases.polylines) {
    CreaseLine mapped{{}, line.closed};
    for (int p : line.points)
      if (index[first_crease + p] >= 0) mapped.vertices.push_back(index[first_crease + p]);
    if (mapped.vertices.size() >= 2) out.crease_lines.push_back(std::move(mapped));
  }
  for (std::size_t k = 0; k < creases.points.size(); ++k) out.crease_points += index[first_crease + k] >= 0;
  out.creases = out.crease_lines.size();
  out.seeds = grown.seeds;
  out.pinched_vertices = grown.pinched_vertices;
  if (out.mesh.faces.rows() > 0) {
    const EdgeAdjacency adjacency = edge_adjacency(out.mesh);
    int count = 0;
    face_components(out.mesh, adjacency, &count);
    out.components = static_cast<std::size_t>(count);
    for (const BoundaryLoop& loop : boundary_loops(out.mesh, adjacency))
      out.loops.push_back({loop.kind, loop.vertices, loop.perimeter});
  }
  return out;
}

}  // namespace cmm::geometry
