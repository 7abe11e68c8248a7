// Each iteration replaces a face normal by the area- and similarity-weighted mean of itself and its
// edge neighbours; the similarity weight is what keeps creases sharp.
#include "geometry/normal_filter.hpp"

#include <cmath>

namespace cmm::geometry {

Points bilateral_filtered_normals(const TriangleMesh& mesh, const EdgeAdjacency& adjacency,
                                  const FaceGeometry& faces, const NormalFilterOptions& options) {
  const Eigen::Index face_count = mesh.faces.rows();
  Points current = faces.normals, next(face_count, 3);
  const double inverse_two_sigma_squared = 1.0 / (2.0 * options.normal_sigma * options.normal_sigma);
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    options.cancel.throw_if_requested("normal filtering");
    for (Eigen::Index f = 0; f < face_count; ++f) {
      const Vec3 n = current.row(f).transpose();
      Vec3 sum = faces.areas[f] * n;
      for (int k = 0; k < 3; ++k) {
        const int g = adjacency.other_face(adjacency.face_edges(f, k), static_cast<int>(f));
        if (g < 0) continue;
        const Vec3 m = current.row(g).transpose();
        sum += faces.areas[g] * std::exp(-(n - m).squaredNorm() * inverse_two_sigma_squared) * m;
      }
      const double length = sum.norm();
      next.row(f) = (length > 0 ? Vec3(sum / length) : n).transpose();
    }
    std::swap(current, next);
  }
  return current;
}

}  // namespace cmm::geometry
