// Topology on hand-built meshes whose answers are known by construction, and on the shared CGAL meshes.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "geometry/boundary_loops.hpp"
#include "geometry/mesh_io.hpp"
#include "geometry/mesh_topology.hpp"

namespace cmm::geometry {
namespace {

TriangleMesh grid(int n, double size) {  // an n × n grid of squares in z = 0, normals +z
  TriangleMesh m;
  m.vertices.resize((n + 1) * (n + 1), 3);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.vertices.row(j * (n + 1) + i) << size * i / n, size * j / n, 0;
  m.faces.resize(2 * n * n, 3);
  int f = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.faces.row(f++) << a, b, d;
      m.faces.row(f++) << a, d, c;
    }
  return m;
}

TriangleMesh without_faces(const TriangleMesh& m, const std::function<bool(const Vec3&)>& drop) {
  TriangleMesh out = m;
  int kept = 0;
  for (int f = 0; f < m.faces.rows(); ++f) {
    const Vec3 c = (vertex(m, m.faces(f, 0)) + vertex(m, m.faces(f, 1)) + vertex(m, m.faces(f, 2))) / 3;
    if (!drop(c)) out.faces.row(kept++) = m.faces.row(f);
  }
  out.faces.conservativeResize(kept, 3);
  return out;
}

TEST(MeshTopology, OpenGridHasOneOuterLoop) {
  const TriangleMesh m = grid(10, 10);
  const EdgeAdjacency adjacency = edge_adjacency(m);
  const TopologyReport report = topology_report(m, adjacency);
  EXPECT_EQ(report.components, 1);
  EXPECT_EQ(report.boundary_edges, 40u);
  EXPECT_EQ(report.non_manifold_edges, 0u);
  EXPECT_EQ(report.inconsistently_oriented_edges, 0u);
  EXPECT_EQ(report.euler_characteristic, 1);
  const auto loops = boundary_loops(m, adjacency);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].kind, LoopKind::outer);
  EXPECT_EQ(loops[0].vertices.size(), 40u);
  EXPECT_NEAR(loops[0].perimeter, 40, 1e-12);
}

// A 10 × 10 square whose left side carries 20 vertices and the others 1 each: the mean of the vertices
// sits 3.2 mm left of the middle, the centre by length in it.
TEST(MeshTopology, ALoopsCentreDoesNotMoveWithHowDenselyItsVerticesLie) {
  TriangleMesh m;
  m.vertices.resize(23, 3);
  for (int i = 0; i <= 20; ++i) m.vertices.row(i) << 0, 10 - 0.5 * i, 0;  // down the left side
  m.vertices.row(21) << 10, 0, 0;
  m.vertices.row(22) << 10, 10, 0;
  std::vector<int> loop;
  for (int i = 0; i <= 22; ++i) loop.push_back(i);
  Vec3 mean = Vec3::Zero();
  for (int v : loop) mean += vertex(m, v) / 23.0;
  EXPECT_LT(mean.x(), 2);
  EXPECT_LT((loop_centre(m, loop) - Vec3(5, 5, 0)).norm(), 1e-12);
}

TEST(MeshTopology, SquareHoleIsClassifiedAsHole) {
  const TriangleMesh m = without_faces(grid(10, 10), [](const Vec3& c) {
    return c.x() > 4 && c.x() < 6 && c.y() > 4 && c.y() < 6;
  });
  const EdgeAdjacency adjacency = edge_adjacency(m);
  const auto loops = boundary_loops(m, adjacency);
  ASSERT_EQ(loops.size(), 2u);
  int holes = 0;
  for (const auto& loop : loops) {
    if (loop.kind == LoopKind::hole) {
      ++holes;
      EXPECT_NEAR(loop.perimeter, 8, 1e-12);
    }
  }
  EXPECT_EQ(holes, 1);
  EXPECT_EQ(topology_report(m, adjacency).euler_characteristic, 0);
}

// A box open at the bottom whose walls lean in by 2° (a scan's noise leans them either way): the normals
// next to the bottom loop turn all the way round and nearly cancel, and what is left of them (down)
// must not decide the loop's kind. It is the outer boundary, the component's only loop.
TEST(MeshTopology, TheOpenBottomOfABoxIsItsOuterBoundaryWhicheverWayTheWallsLean) {
  for (double lean_deg : {-2.0, 2.0}) {
    const double e = 10 * std::tan(lean_deg * 3.141592653589793 / 180);  // the bottom rim's inset
    TriangleMesh m;
    m.vertices.resize(8, 3);
    m.vertices << 0, 0, 10, 10, 0, 10, 10, 10, 10, 0, 10, 10,  //
        e, e, 0, 10 - e, e, 0, 10 - e, 10 - e, 0, e, 10 - e, 0;
    m.faces.resize(10, 3);
    m.faces.row(0) << 0, 1, 2;
    m.faces.row(1) << 0, 2, 3;
    for (int i = 0; i < 4; ++i) {
      const int a = i, b = (i + 1) % 4, c = 4 + i, d = 4 + (i + 1) % 4;
      m.faces.row(2 + 2 * i) << c, d, b;
      m.faces.row(3 + 2 * i) << c, b, a;
    }
    const auto loops = boundary_loops(m, edge_adjacency(m));
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_EQ(loops[0].kind, LoopKind::outer) << "walls leaning " << lean_deg << "°";
  }
}

TEST(MeshTopology, TwoPiecesAreTwoComponents) {
  const TriangleMesh m = without_faces(grid(10, 10), [](const Vec3& c) { return c.x() > 4 && c.x() < 5; });
  EXPECT_EQ(topology_report(m, edge_adjacency(m)).components, 2);
}

TEST(MeshTopology, FlippedFaceIsReportedAsInconsistent) {
  TriangleMesh m = grid(2, 2);
  m.faces.row(0) = Eigen::RowVector3i(m.faces(0, 0), m.faces(0, 2), m.faces(0, 1));
  // Face 0 has three edges: two interior ones now disagree with their neighbours.
  EXPECT_EQ(topology_report(m, edge_adjacency(m)).inconsistently_oriented_edges, 2u);
}

TEST(MeshTopology, ThirdFaceOnAnEdgeIsNonManifold) {
  TriangleMesh m = grid(1, 1);  // two triangles sharing the diagonal 0–3
  m.vertices.conservativeResize(5, 3);
  m.vertices.row(4) << 0.5, 0.5, 1;
  m.faces.conservativeResize(3, 3);
  m.faces.row(2) << 0, 3, 4;
  const TopologyReport report = topology_report(m, edge_adjacency(m));
  EXPECT_EQ(report.non_manifold_edges, 1u);
  EXPECT_FALSE(report.closed());
}

TEST(MeshTopology, FandiskIsOneClosedComponent) {
  const TriangleMesh m = read_mesh(CMMD_TEST_DATA_DIR "/fandisk.ply");
  const EdgeAdjacency adjacency = edge_adjacency(m);
  const TopologyReport report = topology_report(m, adjacency);
  EXPECT_EQ(report.components, 1);
  EXPECT_EQ(report.boundary_edges, 0u);
  EXPECT_EQ(report.non_manifold_edges, 0u);
  EXPECT_EQ(report.inconsistently_oriented_edges, 0u);
  EXPECT_EQ(report.euler_characteristic, 2);
  EXPECT_TRUE(boundary_loops(m, adjacency).empty());
}

TEST(MeshTopology, BladeHasTwoBoundaryLoops) {
  const TriangleMesh m = read_mesh(CMMD_TEST_DATA_DIR "/blade.ply");
  const EdgeAdjacency adjacency = edge_adjacency(m);
  const TopologyReport report = topology_report(m, adjacency);
  EXPECT_EQ(report.components, 1);
  EXPECT_EQ(report.boundary_edges, 240u);
  EXPECT_EQ(report.non_manifold_edges, 0u);
  EXPECT_EQ(report.euler_characteristic, 0);
  const auto loops = boundary_loops(m, adjacency);
  ASSERT_EQ(loops.size(), 2u);
  EXPECT_EQ(loops[0].vertices.size() + loops[1].vertices.size(), 240u);
}

}  // namespace
}  // namespace cmm::geometry
