// Exact contact against the scene: the mesh sweep for part and plate, a quadratic for the sphere.
#include "sim/scene.hpp"

#include <cmath>

namespace cmm::sim {

geometry::TriangleMesh transformed(const geometry::TriangleMesh& mesh, const Eigen::Isometry3d& T) {
  geometry::TriangleMesh out = mesh;
  for (Eigen::Index v = 0; v < out.vertices.rows(); ++v) {
    out.vertices.row(v) = (T * Vec3(mesh.vertices.row(v).transpose())).transpose();
    if (out.vertex_normals.rows() == out.vertices.rows())
      out.vertex_normals.row(v) = (T.linear() * Vec3(mesh.vertex_normals.row(v).transpose())).transpose();
  }
  return out;
}

namespace {
geometry::TriangleMesh merged(const geometry::TriangleMesh& a, const geometry::TriangleMesh& b) {
  geometry::TriangleMesh out;
  out.vertices.resize(a.vertices.rows() + b.vertices.rows(), 3);
  out.vertices << a.vertices, b.vertices;
  out.faces.resize(a.faces.rows() + b.faces.rows(), 3);
  out.faces << a.faces, (b.faces.array() + static_cast<int>(a.vertices.rows())).matrix();
  return out;
}
}  // namespace

SceneContact::SceneContact(const Scene& scene)
    : solids_(merged(scene.part, scene.plate)), sphere_centre_(scene.sphere_centre), sphere_radius_(scene.sphere_radius) {}

std::optional<SceneContact::Hit> SceneContact::first_hit(const Vec3& start, const Vec3& direction, double max_travel,
                                                         double radius) const {
  std::optional<Hit> best;
  if (auto hit = solids_.first_hit(start, direction, max_travel, radius)) best = Hit{hit->travel, hit->centre};

  if (sphere_radius_ > 0) {
    // |start + t·d − c| = R + r: t² + 2t·(d·w) + |w|² − (R + r)² = 0 with w = start − c.
    const Vec3 d = direction.normalized(), w = start - sphere_centre_;
    const double reach = sphere_radius_ + radius;
    const double b = d.dot(w), c = w.squaredNorm() - reach * reach;
    std::optional<double> t;
    if (c < -2 * reach * geometry::kSweepTouch) {
      t = 0;  // overlapping already
    } else if (b < 0 && b * b - c >= 0) {
      double first = -b - std::sqrt(b * b - c);
      if (first <= max_travel) t = std::max(0.0, first);
    }
    if (t && (!best || *t < best->travel)) best = Hit{*t, start + *t * d};
  }
  return best;
}

}  // namespace cmm::sim
