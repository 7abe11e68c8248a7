// The gate before planning (planner/model_limits.hpp): what no placement fits in the travel box
// and what is over the documented counts is refused, naming the vertex that is off (issue 13, D2).
#include "planner/model_limits.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "geometry/analytic_parts.hpp"
#include "geometry/mesh_io.hpp"
#include "hal/description/machine_description.hpp"

namespace cmm::planner {
namespace {

using geometry::Vec3;

using ::testing::HasSubstr;

std::string refusal(const geometry::TriangleMesh& mesh, const description::TravelBox& box, const ModelLimits& limits = {}) {
  try {
    check_model_limits(mesh, box, "part.stl (scale 1)", limits);
  } catch (const ModelRefused& e) {
    return e.what();
  }
  return "";
}

TEST(ModelLimits, ThePartsOfTheTestsFitTheDefaultMachine) {
  const description::TravelBox box = description::default_machine().travel_box;
  for (const std::string& name : geometry::analytic_part_names())
    EXPECT_EQ(refusal(geometry::make_analytic_part(name, 2).mesh, box), "") << name;
}

// Meshes nobody on the project made (tests/data: a CAD export, an open scanned blade) and a CAD
// box of 12 triangles almost as large as the travel box: the gate must not refuse real parts.
TEST(ModelLimits, RealMeshesAndAFewHugeTrianglesScaledToAPartFitTheDefaultMachine) {
  const description::TravelBox box = description::default_machine().travel_box;
  for (const char* name : {"fandisk.ply", "blade.ply"}) {
    geometry::TriangleMesh mesh = geometry::read_mesh(std::string(CMMD_TEST_DATA_DIR) + "/" + name);
    const double extent = (mesh.vertices.colwise().maxCoeff() - mesh.vertices.colwise().minCoeff()).maxCoeff();
    mesh.vertices *= 200 / extent;  // 200 mm across, wherever the file put it
    EXPECT_EQ(refusal(mesh, box), "") << name;
  }
  const double side = 0.9 * (box.max - box.min).minCoeff();
  const geometry::TriangleMesh block = geometry::make_cube(side, side).mesh;  // the coarsest tessellation
  EXPECT_LE(block.faces.rows(), 12 * 4);
  EXPECT_EQ(refusal(block, box), "");
}

TEST(ModelLimits, AStrayVertexIsNamedWithWhereItIs) {
  geometry::TriangleMesh cube = geometry::make_cube(40, 5).mesh;
  cube.vertices.row(17) << 2.6e6, 40, 40;  // 2.6 km away
  const std::string why = refusal(cube, description::default_machine().travel_box);
  EXPECT_THAT(why, HasSubstr("part.stl (scale 1): the model spans"));
  EXPECT_THAT(why, HasSubstr("the farthest vertex is 17 at (2600000.000, 40.000, 40.000)"));
  EXPECT_THAT(why, HasSubstr("stray vertex"));
}

TEST(ModelLimits, SizesAreComparedNotPositions) {
  const description::TravelBox box{Vec3(0, 0, 0), Vec3(300, 400, 0)};  // diagonal 500 mm
  geometry::TriangleMesh rod = geometry::make_cube(10, 5).mesh;
  // Far from the box, and along an axis longer than any side: it fits along the diagonal.
  rod.vertices.col(0) = rod.vertices.col(0) * 49.0 + Eigen::VectorXd::Constant(rod.vertices.rows(), -1e5);
  EXPECT_EQ(refusal(rod, box), "");
  rod.vertices.col(0) *= 1.03;  // 505 mm long
  EXPECT_THAT(refusal(rod, box), HasSubstr("more than the travel box's diagonal of 500.0 mm"));
}

TEST(ModelLimits, CountsOverTheLimitsAreRefused) {
  const geometry::TriangleMesh block = geometry::make_case3_block(2).mesh;
  ModelLimits limits;
  limits.max_faces = static_cast<std::size_t>(block.faces.rows()) - 1;
  EXPECT_THAT(refusal(block, description::default_machine().travel_box, limits), HasSubstr("triangles, more than the limit of"));
  limits = {};
  limits.max_vertices = 10;
  EXPECT_THAT(refusal(block, description::default_machine().travel_box, limits), HasSubstr("vertices, more than the limit of 10"));
}

}  // namespace
}  // namespace cmm::planner
