// Triangle mesh value type: plain Eigen matrices, one row per vertex and per face (libigl's habit).
// Every function in geometry/ takes and returns these; coordinates are in the file's unit (mm in cmmd).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>  // Vec3::cross

namespace cmm::geometry {

using Vec3 = Eigen::Vector3d;
// Row-major so a row is three contiguous doubles: file I/O and k-NN read them in place.
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Triangles = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

struct TriangleMesh {
  Points vertices;        // V × 3
  Triangles faces;        // F × 3, counter-clockwise seen from outside (outward normal)
  Points vertex_normals;  // V × 3 when the file had them, else 0 × 3
};

inline Vec3 vertex(const TriangleMesh& m, int v) { return m.vertices.row(v).transpose(); }

}  // namespace cmm::geometry
