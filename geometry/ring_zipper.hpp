// Triangulates the band between two closed rings of points with different counts, as the analytic-part
// meshers need between neighbouring rings of a surface of revolution or around a hole in a face.
#pragma once

#include <array>
#include <vector>

namespace cmm::geometry {

// Both rings run the same way round and start near each other; a ring of one point (a pole) is a fan
// centre. Walking both rings, each step closes the shorter of the two candidate diagonals.
// Corners index a and then b: k < a.size() is a[k], otherwise b[k - a.size()]. Triangles come as
// (a_i, a_i+1, b_j) and (a_i, b_j+1, b_j), so their normals point along (a_i+1 − a_i) × (b_j − a_i):
// outward for a surface of revolution with b above a, up for a plane annulus with b inside a
// when the rings run counter-clockwise seen from +z.
template <class Point>
std::vector<std::array<int, 3>> zip_rings(const std::vector<Point>& a, const std::vector<Point>& b) {
  const int na = static_cast<int>(a.size()), nb = static_cast<int>(b.size());
  const auto in_a = [&](int i) { return i % na; };
  const auto in_b = [&](int j) { return na + j % nb; };
  const auto point = [&](int corner) -> const Point& { return corner < na ? a[corner] : b[corner - na]; };
  const auto distance = [&](int u, int v) { return (point(u) - point(v)).norm(); };
  // A pole contributes no edges of its own: only the other ring advances.
  const int steps_a = na == 1 ? 0 : na, steps_b = nb == 1 ? 0 : nb;
  std::vector<std::array<int, 3>> triangles;
  for (int i = 0, j = 0; i < steps_a || j < steps_b;) {
    if (j == steps_b || (i < steps_a && distance(in_a(i + 1), in_b(j)) < distance(in_a(i), in_b(j + 1)))) {
      triangles.push_back({in_a(i), in_a(i + 1), in_b(j)});
      ++i;
    } else {
      triangles.push_back({in_a(i), in_b(j + 1), in_b(j)});
      ++j;
    }
  }
  return triangles;
}

}  // namespace cmm::geometry
