// Vertex and triangle collector for the analytic-part meshers, welding vertices by exact coordinates.
// Two surfaces that compute a seam vertex from the same numbers then share it, so the mesh is watertight.
#pragma once

#include <array>
#include <cstddef>
#include <unordered_map>
#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

class MeshBuilder {
 public:
  // The index of the vertex at exactly p, added on first use.
  int vertex(const Vec3& p);
  // a, b, c counter-clockwise seen from outside.
  void triangle(int a, int b, int c) { faces_.push_back({a, b, c}); }
  // p0..p3 counter-clockwise seen from outside; split along p0–p2 or along p1–p3.
  void quad(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, bool split_02);
  TriangleMesh finish() const;

 private:
  struct CoordinateHash {
    std::size_t operator()(const std::array<double, 3>& p) const;
  };
  std::vector<Vec3> vertices_;
  std::vector<std::array<int, 3>> faces_;
  std::unordered_map<std::array<double, 3>, int, CoordinateHash> index_of_;
};

}  // namespace cmm::geometry
