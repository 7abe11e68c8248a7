// Face normals from the winding: (b − a) × (c − a).
#include "geometry/face_geometry.hpp"

namespace cmm::geometry {

FaceGeometry face_geometry(const TriangleMesh& mesh) {
  const Eigen::Index face_count = mesh.faces.rows();
  FaceGeometry g;
  g.normals.resize(face_count, 3);
  g.areas.resize(face_count);
  for (Eigen::Index f = 0; f < face_count; ++f) {
    const Vec3 a = vertex(mesh, mesh.faces(f, 0)), b = vertex(mesh, mesh.faces(f, 1)), c = vertex(mesh, mesh.faces(f, 2));
    const Vec3 cross = (b - a).cross(c - a);
    const double twice_area = cross.norm();
    g.areas[f] = 0.5 * twice_area;
    g.normals.row(f) = (twice_area > 0 ? Vec3(cross / twice_area) : Vec3::Zero()).transpose();
  }
  return g;
}

}  // namespace cmm::geometry
