// Occlusion by an exact ray–triangle test (Möller–Trumbore in double) walked over geometry::TriangleBvh
// nearest-first, stopping at the first hit. Not BallSweeper::first_hit with a tiny radius: a ball that
// starts on the surface overlaps it at once, so it would need an offset start that hides thin occluders.
#include "sim/visibility.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace cmm::sim {

namespace {

using geometry::Vec3;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Entry distance of the ray into the box (0 when it starts inside), +∞ when it misses it.
double ray_box_entry(const Vec3& origin, const Vec3& direction, const Vec3& lo, const Vec3& hi) {
  double enter = 0, leave = kInfinity;
  for (int k = 0; k < 3; ++k) {
    if (direction[k] == 0) {  // parallel to the slab: inside it or never
      if (origin[k] < lo[k] || origin[k] > hi[k]) return kInfinity;
      continue;
    }
    double t0 = (lo[k] - origin[k]) / direction[k], t1 = (hi[k] - origin[k]) / direction[k];
    if (t0 > t1) std::swap(t0, t1);
    enter = std::max(enter, t0);
    leave = std::min(leave, t1);
  }
  return enter <= leave ? enter : kInfinity;
}

// Distance along the ray to the triangle, +∞ if the ray misses it or runs in its plane. Edges count as
// hits, so a beam through the seam of two occluding faces does not slip between them.
double ray_triangle(const Vec3& origin, const Vec3& direction, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a;
  const Vec3 p = direction.cross(ac);
  const double det = ab.dot(p);
  if (det == 0) return kInfinity;
  const Vec3 s = origin - a;
  const double u = s.dot(p) / det;
  if (u < 0 || u > 1) return kInfinity;
  const Vec3 q = s.cross(ab);
  const double v = direction.dot(q) / det;
  if (v < 0 || u + v > 1) return kInfinity;
  const double t = ac.dot(q) / det;
  return t >= 0 ? t : kInfinity;
}

// The tree needs finite coordinates and faces that index vertices; say so before it is built.
const geometry::TriangleMesh& checked(const geometry::TriangleMesh& scene) {
  if (!scene.vertices.allFinite()) throw std::invalid_argument("scan visibility: a scene coordinate is not finite");
  if (scene.faces.size() > 0 && (scene.faces.minCoeff() < 0 || scene.faces.maxCoeff() >= scene.vertices.rows()))
    throw std::invalid_argument("scan visibility: a face index is out of range");
  return scene;
}

}  // namespace

ScanVisibility::ScanVisibility(const geometry::TriangleMesh& scene, double max_incidence_deg)
    : scene_{scene.vertices, scene.faces, geometry::Points(0, 3)},
      faces_(geometry::face_geometry(checked(scene_))),
      tree_(scene_) {
  if (!(max_incidence_deg > 0 && max_incidence_deg < 90))
    throw std::invalid_argument("scan visibility: max_incidence_deg must be in (0, 90)");
  cos_limit_ = std::cos(max_incidence_deg * std::numbers::pi / 180);
  // A relative nanometre-scale floor: far above double rounding on the part, far below any real occluder.
  const double size = scene_.vertices.rows() > 0
                          ? (scene_.vertices.colwise().maxCoeff() - scene_.vertices.colwise().minCoeff()).norm()
                          : 0;
  self_hit_ = 1e-9 * std::max(size, 1.0);
}

bool ScanVisibility::facing(int face, const Vec3& view_direction) const {
  // The normal against the beam back toward the scanner: cos of the incidence angle; 0 for a degenerate face.
  return -view_direction.dot(faces_.normals.row(face).transpose()) > cos_limit_;
}

bool ScanVisibility::occluded(const Vec3& point, int face, const Vec3& view_direction) const {
  const Vec3 beam = -view_direction;
  bool hit = false;
  tree_.nearest_first(
      kInfinity,
      [&](const Vec3& lo, const Vec3& hi, double) { return ray_box_entry(point, beam, lo, hi); },
      [&](int first, int count, double limit) {
        for (int slot = first; slot < first + count; ++slot) {
          const int f = tree_.order()[slot];
          if (f == face) continue;
          const double t = ray_triangle(point, beam, geometry::vertex(scene_, scene_.faces(f, 0)),
                                        geometry::vertex(scene_, scene_.faces(f, 1)),
                                        geometry::vertex(scene_, scene_.faces(f, 2)));
          if (t > self_hit_ && t < kInfinity) {
            hit = true;
            return -kInfinity;  // any occluder will do: prune everything that is left
          }
        }
        return limit;
      });
  return hit;
}

}  // namespace cmm::sim
