// The bundled sample part (config/samples) must stay what the generator makes, so the demo, the
// docs and the tests all talk about the same part.
#include <gtest/gtest.h>

#include "geometry/analytic_parts.hpp"
#include "geometry/mesh_io.hpp"

namespace cmm::geometry {
namespace {

TEST(SamplePart, MatchesTheCase3BlockGenerator) {
  const TriangleMesh sample = read_mesh(CMMD_SOURCE_DIR "/config/samples/case3_block.ply");
  const AnalyticPart part = make_case3_block(2.0);
  ASSERT_EQ(sample.vertices.rows(), part.mesh.vertices.rows())
      << "regenerate with: make-analytic-part case3_block --edge-length 2 -o config/samples/case3_block.ply";
  ASSERT_EQ(sample.faces, part.mesh.faces);
  EXPECT_LT((sample.vertices - part.mesh.vertices).cwiseAbs().maxCoeff(), 1e-12);
}

}  // namespace
}  // namespace cmm::geometry
