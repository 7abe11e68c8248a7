// Sharp edges of a nominal model by their dihedral angle, and its holes as circles fitted to them.
#include "planner/nominal_model.hpp"

#include <algorithm>
#include <bitset>
#include <cmath>
#include <numbers>

#include "geometry/circle_fit.hpp"
#include "geometry/edge_adjacency.hpp"
#include "geometry/face_geometry.hpp"

namespace cmm::planner {

NominalModel nominal_model(const geometry::TriangleMesh& mesh, const Eigen::Isometry3d& T_S_N, double feature_angle_deg) {
  geometry::TriangleMesh placed = mesh;
  for (int v = 0; v < placed.vertices.rows(); ++v)
    placed.vertices.row(v) = (T_S_N * geometry::vertex(mesh, v)).transpose();
  placed.vertex_normals.resize(0, 3);

  const geometry::EdgeAdjacency adjacency = geometry::edge_adjacency(placed);
  const geometry::FaceGeometry faces = geometry::face_geometry(placed);
  // A nominal is exact: an edge is sharp when its facets meet at more than the angle, with none of
  // the reference's noise handling. (That handling also drops closed curves shorter than a few mean
  // edge lengths, and a CAD export's edges are long: a Ø10 rim beside 40 mm facets would go.)
  const double cos_sharp = std::cos(feature_angle_deg * std::numbers::pi / 180);

  NominalModel model;
  for (int e = 0; e < adjacency.edge_count(); ++e) {
    const int f0 = geometry::EdgeAdjacency::face_of(adjacency.half_edge(e, 0));
    const int f1 = adjacency.use_count(e) >= 2 ? geometry::EdgeAdjacency::face_of(adjacency.half_edge(e, 1)) : f0;
    const bool open = adjacency.use_count(e) == 1;
    const bool sharp = adjacency.use_count(e) == 2 && faces.normals.row(f0).dot(faces.normals.row(f1)) < cos_sharp;
    if (!sharp && !open) continue;
    model.edges.push_back({geometry::vertex(placed, adjacency.edges(e, 0)), geometry::vertex(placed, adjacency.edges(e, 1)),
                           faces.normals.row(f0).transpose(), faces.normals.row(f1).transpose()});
  }
  return model;
}

std::optional<NearestNominalEdge> nearest_nominal_edge(const NominalModel& model, const Vec3& p, double reach_mm) {
  std::optional<NearestNominalEdge> best;
  for (const NominalEdge& edge : model.edges) {
    const Vec3 ab = edge.b - edge.a;
    const double length_squared = ab.squaredNorm();
    const double t = length_squared > 0 ? std::clamp((p - edge.a).dot(ab) / length_squared, 0.0, 1.0) : 0.0;
    const Vec3 q = edge.a + t * ab;
    const double d = (p - q).norm();
    if (d <= reach_mm && (!best || d < best->distance_mm)) best = NearestNominalEdge{q, &edge, d};
  }
  return best;
}

std::optional<NominalHole> nominal_hole_near(const NominalModel& model, const Vec3& rim_centre, const Vec3& axis,
                                             double radius) {
  const Vec3 a = axis.normalized();
  const Vec3 u = a.unitOrthogonal(), w = a.cross(u);
  const double band = std::max(0.5, radius / 4);
  std::vector<Vec3> rim;
  std::bitset<8> octants;
  for (const NominalEdge& edge : model.edges)
    for (const Vec3& p : {edge.a, edge.b}) {
      const Vec3 v = p - rim_centre;
      const double along = v.dot(a);
      const Vec3 across = v - along * a;
      if (std::abs(along) > 1.0 || std::abs(across.norm() - radius) > band) continue;
      rim.push_back(p);
      const double angle = std::atan2(across.dot(w), across.dot(u));
      octants.set(static_cast<std::size_t>(std::clamp(static_cast<int>((angle + std::numbers::pi) / (std::numbers::pi / 4)), 0, 7)));
    }
  if (rim.size() < 6 || octants.count() < 4) return std::nullopt;
  const geometry::Circle3 circle = geometry::fit_circle(rim);
  if (circle.radius <= 0) return std::nullopt;
  return NominalHole{circle.centre, circle.normal.dot(a) < 0 ? Vec3(-circle.normal) : circle.normal, circle.radius};
}

}  // namespace cmm::planner
