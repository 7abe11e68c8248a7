// The vertex-noise estimate on inputs nobody makes on purpose and on the ones users bring: it measures
// the vertices, not the tessellation, and its work stays bounded.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "geometry/analytic_parts.hpp"
#include "geometry/edge_adjacency.hpp"
#include "geometry/face_geometry.hpp"
#include "geometry/surface_noise.hpp"

namespace cmm::geometry {
namespace {

SurfaceNoise noise_of(const TriangleMesh& mesh) {
  return surface_noise(mesh, edge_adjacency(mesh), face_geometry(mesh), 30 * std::numbers::pi / 180);
}

TEST(SurfaceNoise, AnExactMeshReadsNoNoiseHoweverItIsCut) {
  for (Tessellation::Style style : {Tessellation::Style::cad, Tessellation::Style::slivers})
    for (const char* part : {"cube", "bicone", "hemisphere_cone"})
      EXPECT_LT(noise_of(make_analytic_part(part, Tessellation{style, 0, 0.025}).mesh).sigma_mm, 1e-3) << part;
}

TEST(SurfaceNoise, ReadsTheNoisePutOnTheVertices) {
  const SurfaceNoise n = noise_of(with_gaussian_noise(make_analytic_part("bicone", 1.0).mesh, 0.05, 7));
  EXPECT_NEAR(n.sigma_mm, 0.05, 0.005);
  EXPECT_GT(n.measured, 1000);
}

// One vertex in 200,000 slivers (a hostile fan): skipped, not grouped at its valence squared.
TEST(SurfaceNoise, AVertexInAHugeFanIsSkippedNotGrouped) {
  const int n = 200'000;
  TriangleMesh fan{Points(n + 1, 3), Triangles(n, 3), Points(0, 3)};
  fan.vertices.row(0) << 0, 0, 1;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    fan.vertices.row(i + 1) << std::cos(a), std::sin(a), 0;
    fan.faces.row(i) << 0, i + 1, (i + 1) % n + 1;
  }
  const SurfaceNoise noise = noise_of(fan);
  EXPECT_EQ(noise.sigma_mm, 0.0);
  EXPECT_EQ(noise.vertex_residual_mm.size(), static_cast<std::size_t>(n + 1));
}

}  // namespace
}  // namespace cmm::geometry
