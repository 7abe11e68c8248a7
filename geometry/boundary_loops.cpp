// Loops follow boundary half-edges head to tail. Classification uses orientation: seen along the
// surface normal next to it, an outer boundary runs counter-clockwise and a hole clockwise. Where
// the surface stands edge-on to the loop (a tube's open end, a box's open bottom: the normals next
// to it turn all the way round and cancel) that is undecided, and the longest loop of the component
// is taken as its outer boundary.
#include "geometry/boundary_loops.hpp"

#include <algorithm>
#include <unordered_map>

#include "geometry/circle_fit.hpp"
#include "geometry/mesh_topology.hpp"

namespace cmm::geometry {
namespace {

struct Orientation {
  double signed_area;     // about the loop plane normal, in the loop's winding
  double normal_agreement;  // mean |surface normal · plane normal|, 1 = surface lies in the plane
};

Orientation loop_orientation(const TriangleMesh& mesh, const BoundaryLoop& loop) {
  std::vector<Vec3> points;
  for (int v : loop.vertices) points.push_back(vertex(mesh, v));
  Vec3 plane = fit_circle(points).normal;
  if (plane.dot(loop.surface_normal) < 0) plane = -plane;
  Vec3 area = Vec3::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) area += points[i].cross(points[(i + 1) % points.size()]);
  return {0.5 * area.dot(plane), std::abs(loop.surface_normal.dot(plane))};
}

}  // namespace

std::vector<BoundaryLoop> boundary_loops(const TriangleMesh& mesh, const EdgeAdjacency& adjacency) {
  // Each boundary half-edge a→b, keyed by a; a vertex touching the boundary twice (a pinch) keeps
  // several, consumed one by one.
  std::unordered_multimap<int, int> outgoing;
  for (int e = 0; e < adjacency.edge_count(); ++e) {
    if (adjacency.use_count(e) != 1) continue;
    const int h = adjacency.half_edge(e, 0);
    outgoing.emplace(mesh.faces(h / 3, h % 3), h);
  }
  if (outgoing.empty()) return {};  // closed: spare the component labelling
  int component_count = 0;
  const std::vector<int> component = face_components(mesh, adjacency, &component_count);

  std::vector<BoundaryLoop> loops;
  std::vector<double> coherence;  // |Σ facet normal| / Σ |facet normal| next to each loop
  while (!outgoing.empty()) {
    BoundaryLoop loop;
    Vec3 normal_sum = Vec3::Zero();
    double length_sum = 0;
    auto it = outgoing.begin();
    const int start = it->first;
    loop.component = component[it->second / 3];
    while (it != outgoing.end()) {
      const int h = it->second, f = h / 3, k = h % 3;
      const int from = mesh.faces(f, k), to = mesh.faces(f, (k + 1) % 3);
      const Vec3 a = vertex(mesh, mesh.faces(f, 0)), b = vertex(mesh, mesh.faces(f, 1)), c = vertex(mesh, mesh.faces(f, 2));
      normal_sum += (b - a).cross(c - a);
      length_sum += (b - a).cross(c - a).norm();
      loop.vertices.push_back(from);
      loop.half_edges.push_back(h);
      loop.perimeter += (vertex(mesh, to) - vertex(mesh, from)).norm();
      outgoing.erase(it);
      if (to == start) break;
      it = outgoing.find(to);
    }
    if (normal_sum.norm() > 0) loop.surface_normal = normal_sum.normalized();
    coherence.push_back(length_sum > 0 ? normal_sum.norm() / length_sum : 0.0);
    loops.push_back(std::move(loop));
  }

  // Classify per component.
  std::vector<int> longest(component_count, -1);
  for (int i = 0; i < static_cast<int>(loops.size()); ++i) {
    int& best = longest[loops[i].component];
    if (best < 0 || loops[i].perimeter > loops[best].perimeter) best = i;
  }
  for (int i = 0; i < static_cast<int>(loops.size()); ++i) {
    const Orientation o = loop_orientation(mesh, loops[i]);
    if (coherence[i] > 0.5 && o.normal_agreement > 0.5)
      loops[i].kind = o.signed_area > 0 ? LoopKind::outer : LoopKind::hole;
    else
      loops[i].kind = longest[loops[i].component] == i ? LoopKind::outer : LoopKind::hole;
  }
  return loops;
}

Vec3 loop_centre(const TriangleMesh& mesh, const std::vector<int>& vertices) {
  Vec3 sum = Vec3::Zero(), mean = Vec3::Zero();
  double length = 0;
  const std::size_t n = vertices.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 a = vertex(mesh, vertices[i]), b = vertex(mesh, vertices[(i + 1) % n]);
    sum += (a + b) / 2 * (b - a).norm();
    length += (b - a).norm();
    mean += a / static_cast<double>(n);
  }
  return length > 0 ? Vec3(sum / length) : mean;
}

}  // namespace cmm::geometry
