// Threshold on dihedral angles, chain, prune short dangling spurs, flag convexity.
#include "geometry/feature_edges.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include "geometry/normal_filter.hpp"

namespace cmm::geometry {
namespace {

// Positive when the edge is convex: each face's far corner lies below the other face's plane.
double convexity(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const Points& normals, int e) {
  double sum = 0;
  for (int i = 0; i < 2; ++i) {
    const int h = adjacency.half_edge(e, i), other = adjacency.half_edge(e, 1 - i);
    const int far_corner = mesh.faces(h / 3, (h % 3 + 2) % 3);
    const Vec3 n_other = normals.row(other / 3).transpose();
    sum -= n_other.dot(vertex(mesh, far_corner) - vertex(mesh, adjacency.edges(e, 0)));
  }
  return sum;
}

struct FeatureGraph {
  std::vector<int> start;  // per vertex, CSR into edges
  std::vector<int> edges;
  int degree(int v) const { return start[v + 1] - start[v]; }
};

FeatureGraph feature_graph(const EdgeAdjacency& adjacency, const std::vector<char>& is_feature, int vertex_count) {
  FeatureGraph g;
  g.start.assign(vertex_count + 1, 0);
  for (int e = 0; e < adjacency.edge_count(); ++e)
    if (is_feature[e]) ++g.start[adjacency.edges(e, 0) + 1], ++g.start[adjacency.edges(e, 1) + 1];
  for (int v = 0; v < vertex_count; ++v) g.start[v + 1] += g.start[v];
  g.edges.resize(g.start.back());
  std::vector<int> fill(g.start.begin(), g.start.end() - 1);
  for (int e = 0; e < adjacency.edge_count(); ++e)
    if (is_feature[e]) g.edges[fill[adjacency.edges(e, 0)]++] = e, g.edges[fill[adjacency.edges(e, 1)]++] = e;
  return g;
}

std::vector<FeatureCurve> chain(const TriangleMesh& mesh, const EdgeAdjacency& adjacency,
                                const std::vector<char>& is_feature) {
  const int vertex_count = static_cast<int>(mesh.vertices.rows());
  const FeatureGraph g = feature_graph(adjacency, is_feature, vertex_count);
  std::vector<char> used(adjacency.edge_count(), 0);
  std::vector<FeatureCurve> curves;
  auto other_end = [&](int e, int v) { return adjacency.edges(e, 0) == v ? adjacency.edges(e, 1) : adjacency.edges(e, 0); };
  auto walk = [&](int from, int e) {
    FeatureCurve curve;
    curve.vertices.push_back(from);
    int at = from;
    while (true) {
      used[e] = 1;
      curve.edges.push_back(e);
      const int next = other_end(e, at);
      curve.length += (vertex(mesh, next) - vertex(mesh, at)).norm();
      at = next;
      if (at == from) { curve.closed = true; break; }
      curve.vertices.push_back(at);
      if (g.degree(at) != 2) break;
      const int a = g.edges[g.start[at]], b = g.edges[g.start[at] + 1];
      e = a == e ? b : a;
      if (used[e]) break;
    }
    curves.push_back(std::move(curve));
  };
  for (int v = 0; v < vertex_count; ++v) {
    if (g.degree(v) == 2) continue;
    for (int i = g.start[v]; i < g.start[v + 1]; ++i)
      if (!used[g.edges[i]]) walk(v, g.edges[i]);
  }
  for (int e = 0; e < adjacency.edge_count(); ++e)  // what is left are loops without junctions
    if (is_feature[e] && !used[e]) walk(adjacency.edges(e, 0), e);
  return curves;
}

// Drops curves that end in nothing and are shorter than min_length, and with drop_short_loops closed
// ones too; and, shorter than min_spoke_length, curves attached to nothing at either end and the
// spokes of a star (a junction whose every curve ends in nothing: a cone tip). Returns the curves
// that remain.
std::vector<FeatureCurve> prune_dangling(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, double min_length,
                                         double min_spoke_length, bool drop_short_loops, std::vector<char>& is_feature) {
  std::vector<FeatureCurve> curves = chain(mesh, adjacency, is_feature);
  const FeatureGraph g = feature_graph(adjacency, is_feature, static_cast<int>(mesh.vertices.rows()));
  auto dangling = [&](const FeatureCurve& c) {
    return !c.closed && (g.degree(c.vertices.front()) == 1 || g.degree(c.vertices.back()) == 1);
  };
  std::map<int, bool> star;  // junction vertex → every curve at it dangles
  for (const FeatureCurve& c : curves) {
    if (c.closed) continue;
    for (int end : {c.vertices.front(), c.vertices.back()})
      if (g.degree(end) > 2) star.try_emplace(end, true).first->second &= dangling(c);
  }
  bool pruned = false;
  for (const FeatureCurve& c : curves) {
    if (drop_short_loops && c.closed && c.length < min_length) {  // a speck of noise closing on itself
      for (int e : c.edges) is_feature[e] = 0;
      pruned = true;
    }
    if (!dangling(c)) continue;
    const int hub = g.degree(c.vertices.front()) > 2 ? c.vertices.front() : c.vertices.back();
    const bool spoke = g.degree(hub) > 2 && star[hub];
    const bool isolated = g.degree(c.vertices.front()) == 1 && g.degree(c.vertices.back()) == 1;
    if (c.length < min_length || ((spoke || isolated) && c.length < min_spoke_length)) {
      for (int e : c.edges) is_feature[e] = 0;
      pruned = true;
    }
  }
  return pruned ? chain(mesh, adjacency, is_feature) : curves;
}

// Hysteresis: from each free end, step onto the weak edge that best continues the curve, as long as
// one turns by less than 45°.
void extend_free_ends(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const std::vector<double>& cos_dihedral,
                      double weak_cos, std::vector<char>& is_feature) {
  const int vertex_count = static_cast<int>(mesh.vertices.rows());
  std::vector<int> degree(vertex_count, 0);
  for (int e = 0; e < adjacency.edge_count(); ++e)
    if (is_feature[e]) ++degree[adjacency.edges(e, 0)], ++degree[adjacency.edges(e, 1)];
  auto other_end = [&](int e, int v) { return adjacency.edges(e, 0) == v ? adjacency.edges(e, 1) : adjacency.edges(e, 0); };
  std::vector<int> ends;
  for (int v = 0; v < vertex_count; ++v)
    if (degree[v] == 1) ends.push_back(v);
  if (ends.empty()) return;
  std::vector<char> all(adjacency.edge_count(), 1);
  const FeatureGraph incident = feature_graph(adjacency, all, vertex_count);  // every edge at a vertex
  const double min_cos = std::cos(std::numbers::pi / 4);
  for (int v : ends) {
    for (int step = 0; step < 64 && degree[v] == 1; ++step) {
      int previous = -1;
      for (int i = incident.start[v]; i < incident.start[v + 1]; ++i)
        if (is_feature[incident.edges[i]]) previous = incident.edges[i];
      const Vec3 direction = (vertex(mesh, v) - vertex(mesh, other_end(previous, v))).normalized();
      int best = -1;
      double best_cos = min_cos;
      for (int i = incident.start[v]; i < incident.start[v + 1]; ++i) {
        const int e = incident.edges[i];
        if (is_feature[e] || adjacency.use_count(e) != 2 || cos_dihedral[e] >= weak_cos) continue;
        const double c = direction.dot((vertex(mesh, other_end(e, v)) - vertex(mesh, v)).normalized());
        if (c > best_cos) best = e, best_cos = c;
      }
      if (best < 0) break;
      is_feature[best] = 1;
      ++degree[v];
      v = other_end(best, v);
      ++degree[v];
    }
  }
}

}  // namespace

FeatureEdges feature_edges(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const FaceGeometry& faces,
                           const FeatureOptions& options) {
  FeatureEdges result;
  const int edge_count = adjacency.edge_count();
  // Cosines rather than angles: the threshold compares the same either way, and the
  // 4M-triangle benchmark has no time for an atan2 per edge.
  std::vector<double> cos_dihedral(edge_count, 1);
  auto cosines = [&](const Points& normals) {
    for (int e = 0; e < edge_count; ++e)
      if (adjacency.use_count(e) == 2)
        cos_dihedral[e] = normals.row(adjacency.half_edge(e, 0) / 3).dot(normals.row(adjacency.half_edge(e, 1) / 3));
  };
  cosines(faces.normals);
  // Every 8th edge of a big mesh is plenty for a mean, and cheaper. The mean edge length turns the vertex
  // noise into the tilt it gives facets, and sizes the spurs pruned as noise.
  const int stride = edge_count > 80'000 ? 8 : 1;
  double length_sum = 0;
  int sampled = 0;
  for (int e = 0; e < edge_count; e += stride, ++sampled)
    length_sum += (mesh.vertices.row(adjacency.edges(e, 0)) - mesh.vertices.row(adjacency.edges(e, 1))).norm();
  result.mean_edge_length = sampled ? length_sum / sampled : 0;
  const double threshold = options.angle_deg * std::numbers::pi / 180;
  result.noise = surface_noise(mesh, adjacency, faces, threshold);
  result.noisy = options.made_from_scan ||
                 (result.mean_edge_length > 0 &&
                  2 * result.noise.sigma_mm / result.mean_edge_length > options.noisy_facet_tilt_deg * std::numbers::pi / 180);

  const Points* normals = &faces.normals;
  if (result.noisy) {
    NormalFilterOptions filter;
    filter.cancel = options.cancel;
    result.filtered_normals = bilateral_filtered_normals(mesh, adjacency, faces, filter);
    normals = &result.filtered_normals;
    cosines(result.filtered_normals);
  }
  const double cos_threshold = std::cos(threshold);
  result.is_feature.assign(edge_count, 0);
  for (int e = 0; e < edge_count; ++e)
    result.is_feature[e] = adjacency.use_count(e) == 2 && cos_dihedral[e] < cos_threshold;

  // Spurs go first, or hysteresis would extend a cone apex's spokes down the cone; a spur also
  // splits the true curve it touches, so chain again once it is gone.
  const double min_length =
      (result.noisy ? options.noisy_min_dangling_edges : options.min_dangling_edges) * result.mean_edge_length;
  const double min_spoke_length =
      (result.noisy ? options.noisy_min_spoke_edges : options.min_spoke_edges) * result.mean_edge_length;
  options.cancel.throw_if_requested("feature edge detection");
  // On an exact mesh a loop of sharp edges is real however short: a Ø10 rim among a CAD export's
  // 40 mm facets is shorter than three mean edges. Only noise closes on itself.
  prune_dangling(mesh, adjacency, min_length, min_spoke_length, result.noisy, result.is_feature);
  options.cancel.throw_if_requested("feature edge detection");
  extend_free_ends(mesh, adjacency, cos_dihedral, std::cos(options.continuation_fraction * threshold), result.is_feature);
  result.curves = prune_dangling(mesh, adjacency, min_length, min_spoke_length, result.noisy, result.is_feature);

  for (FeatureCurve& c : result.curves) {
    double convex_length = 0;
    for (int e : c.edges) {
      const double length = (vertex(mesh, adjacency.edges(e, 0)) - vertex(mesh, adjacency.edges(e, 1))).norm();
      if (convexity(mesh, adjacency, *normals, e) > 0) convex_length += length;
    }
    c.convex = convex_length >= 0.5 * c.length;
  }
  return result;
}

}  // namespace cmm::geometry
