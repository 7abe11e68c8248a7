// Visibility is judged on the true mesh and the noise drawn on every true vertex, kept or not, so the
// noise a vertex gets does not depend on which faces the views happen to see.
#include "sim/scanned_mesh.hpp"

#include <cmath>
#include <stdexcept>

#include "geometry/analytic_parts.hpp"
#include "geometry/face_geometry.hpp"

namespace cmm::sim {

ScannedMesh synthesize_scanned_mesh(const geometry::TriangleMesh& true_mesh, const ScannedMeshOptions& o) {
  if (!(o.noise_sigma_mm >= 0) || !std::isfinite(o.noise_sigma_mm))
    throw std::invalid_argument("scanned mesh: noise_sigma_mm must be finite and >= 0");
  check_views(o.views, "scanned mesh: views");
  const ScanVisibility visibility(true_mesh, o.max_incidence_deg);

  ScannedMesh out;
  std::vector<int> kept_faces;
  for (int f = 0; f < true_mesh.faces.rows(); ++f) {
    const geometry::Vec3 centroid = geometry::face_centroid(true_mesh, f);
    bool seen = false;
    for (const ScanView& view : o.views) seen = seen || visibility.sees(centroid, f, view.direction);
    (seen ? kept_faces : out.removed_faces).push_back(f);
  }

  // with_gaussian_noise wants a positive σ (std::normal_distribution's precondition).
  const geometry::Points noisy = o.noise_sigma_mm > 0
                                     ? geometry::with_gaussian_noise(true_mesh, o.noise_sigma_mm, o.seed).vertices
                                     : true_mesh.vertices;
  std::vector<int> renumbered(true_mesh.vertices.rows(), -1);
  out.mesh.faces.resize(static_cast<Eigen::Index>(kept_faces.size()), 3);
  for (int k = 0; k < static_cast<int>(kept_faces.size()); ++k)
    for (int c = 0; c < 3; ++c) {
      int& v = renumbered[true_mesh.faces(kept_faces[k], c)];
      if (v < 0) {
        v = static_cast<int>(out.true_vertex.size());
        out.true_vertex.push_back(true_mesh.faces(kept_faces[k], c));
      }
      out.mesh.faces(k, c) = v;
    }
  out.mesh.vertices.resize(static_cast<Eigen::Index>(out.true_vertex.size()), 3);
  for (int v = 0; v < static_cast<int>(out.true_vertex.size()); ++v) out.mesh.vertices.row(v) = noisy.row(out.true_vertex[v]);
  out.mesh.vertex_normals.resize(0, 3);
  return out;
}

}  // namespace cmm::sim
