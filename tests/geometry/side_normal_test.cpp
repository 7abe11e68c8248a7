// One side's normal at an edge on a clean mesh: what it states must come from the facets it rests on.
// A CAD export cuts a plane beside a blade's edge into slivers a few micrometres wide; the mesh's noise
// figure (a few micrometres, from its blends) must not be read as noise on that plane's vertices.
#include <gtest/gtest.h>

#include <numeric>
#include <vector>

#include "geometry/face_geometry.hpp"
#include "geometry/side_normal.hpp"

namespace cmm::geometry {
namespace {

// A flat strip along x at z = 0, `depth` wide in y, cut into `columns` quads of two triangles each, every
// triangle's normal +z; the edge runs along y = 0.
TriangleMesh strip(double length, double depth, int columns) {
  TriangleMesh mesh;
  mesh.vertices.resize(2 * (columns + 1), 3);
  for (int i = 0; i <= columns; ++i) {
    const double x = length * i / columns;
    mesh.vertices.row(2 * i) << x, 0, 0;
    mesh.vertices.row(2 * i + 1) << x, depth, 0;
  }
  mesh.faces.resize(2 * columns, 3);
  for (int i = 0; i < columns; ++i) {
    mesh.faces.row(2 * i) << 2 * i, 2 * i + 2, 2 * i + 3;
    mesh.faces.row(2 * i + 1) << 2 * i, 2 * i + 3, 2 * i + 1;
  }
  return mesh;
}

TEST(SideNormal, APlaneCutIntoSliversStatesNoNoise) {
  // 2 mm of edge in 400 columns: slivers 5 µm wide and 1 mm deep, on a mesh whose noise figure is 3.4 µm.
  const TriangleMesh mesh = strip(2.0, 1.0, 400);
  const FaceGeometry faces = face_geometry(mesh);
  std::vector<int> region(static_cast<std::size_t>(mesh.faces.rows()));
  std::iota(region.begin(), region.end(), 0);
  std::swap(region[0], region[400]);  // the seed: a facet touching the edge near the point
  const SideNormal side = side_normal(mesh, faces, region, Vec3(1.0, 0, 0), Vec3::UnitX(), Vec3::Zero(),
                                      CleanNoise{0.0034, 0.0034});
  EXPECT_NEAR(side.normal.z(), 1.0, 1e-12);
  // Taken as independent noise on each sliver's corners, the 3.4 µm figure would state 0.28° here.
  EXPECT_LT(side.uncertainty_rad, 1e-6);
}

}  // namespace
}  // namespace cmm::geometry
