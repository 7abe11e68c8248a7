// Welds by exact coordinates; +0 and -0 compare and hash equal, so a seam on a zero plane still welds.
#include "geometry/mesh_builder.hpp"

#include <functional>

namespace cmm::geometry {

std::size_t MeshBuilder::CoordinateHash::operator()(const std::array<double, 3>& p) const {
  std::size_t h = 0;
  for (double c : p) h = (h * 1000003u) ^ std::hash<double>{}(c);
  return h;
}

int MeshBuilder::vertex(const Vec3& p) {
  const auto [it, inserted] = index_of_.try_emplace({p.x(), p.y(), p.z()}, static_cast<int>(vertices_.size()));
  if (inserted) vertices_.push_back(p);
  return it->second;
}

void MeshBuilder::quad(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, bool split_02) {
  const int a = vertex(p0), b = vertex(p1), c = vertex(p2), d = vertex(p3);
  if (split_02) {
    triangle(a, b, c);
    triangle(a, c, d);
  } else {
    triangle(a, b, d);
    triangle(b, c, d);
  }
}

TriangleMesh MeshBuilder::finish() const {
  TriangleMesh mesh;
  mesh.vertices.resize(std::ssize(vertices_), 3);
  for (Eigen::Index i = 0; i < mesh.vertices.rows(); ++i) mesh.vertices.row(i) = vertices_[i];
  mesh.faces.resize(std::ssize(faces_), 3);
  for (Eigen::Index i = 0; i < mesh.faces.rows(); ++i)
    for (int k = 0; k < 3; ++k) mesh.faces(i, k) = faces_[i][k];
  mesh.vertex_normals.resize(0, 3);
  return mesh;
}

}  // namespace cmm::geometry
