// The one reference-model loader: the sample part reads into a mesh with its features and inputs,
// and every way a model file gives none is a ModelError of its kind, naming the file.
#include "planner/reference_model.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace cmm::planner {
namespace {

namespace fs = std::filesystem;

const description::TravelBox box = description::default_machine().travel_box;

ModelError::Kind kind_of(const fs::path& file, const ReferenceModelOptions& options = {}) {
  try {
    load_reference_model(file, box, options);
  } catch (const ModelError& e) {
    EXPECT_EQ(e.file, file);
    EXPECT_NE(std::string(e.what()).find(file.filename().string()), std::string::npos) << e.what();
    return e.kind;
  }
  ADD_FAILURE() << file << " gave a reference model";
  return ModelError::Kind::features;
}

TEST(ReferenceModel, TheSamplePartWithItsFeaturesAndInputs) {
  ReferenceModelOptions options;
  options.scale = 1;
  options.spacing = 4;
  const fs::path file = fs::path(CMMD_SOURCE_DIR) / "config" / "samples" / "case3_block.ply";
  const ReferenceModel m = load_reference_model(file, box, options);
  EXPECT_GT(m.mesh.faces.rows(), 1000);
  EXPECT_GT(m.features.points.size(), 100u);
  EXPECT_EQ(m.features.holes.size(), 5u);
  EXPECT_EQ(m.inputs.model_file, file);
  EXPECT_EQ(m.inputs.spacing, 4);
  EXPECT_EQ(m.inputs.face_count, static_cast<std::size_t>(m.mesh.faces.rows()));
  options.scale = 2;  // a unit conversion scales the mesh before anything is looked for
  EXPECT_NEAR(load_reference_model(file, box, options).mesh.vertices.maxCoeff(), 2 * m.mesh.vertices.maxCoeff(), 1e-9);
}

TEST(ReferenceModel, EachRefusalIsItsKind) {
  const fs::path data(CMMD_TEST_DATA_DIR);
  EXPECT_EQ(kind_of(data / "broken" / "truncated.ply"), ModelError::Kind::unreadable);
  EXPECT_EQ(kind_of(data / "no_such_file.stl"), ModelError::Kind::unreadable);
  const fs::path dir = fs::temp_directory_path() / ("cmmd_reference_model_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "cloud.xyz") << "0 0 0\n1 0 0\n0 1 0\n";
  EXPECT_EQ(kind_of(dir / "cloud.xyz"), ModelError::Kind::scan);
  EXPECT_EQ(kind_of(data / "hostile" / "huge_tetrahedron.ply"), ModelError::Kind::too_large);
  ReferenceModelOptions huge;
  huge.scale = 1e308;
  const fs::path sample = fs::path(CMMD_SOURCE_DIR) / "config" / "samples" / "case3_block.ply";
  EXPECT_EQ(kind_of(sample, huge), ModelError::Kind::out_of_range);
  ReferenceModelOptions dense;
  dense.spacing = 0.01;  // tens of thousands of points on the block's edges
  try {
    load_reference_model(sample, box, dense);
    ADD_FAILURE() << "no limit on the points";
  } catch (const ModelError& e) {
    EXPECT_EQ(e.kind, ModelError::Kind::too_many_points);
    EXPECT_GT(e.points, e.limit);
    EXPECT_EQ(e.limit, ModelLimits{}.max_edge_points);
  }
  fs::remove_all(dir);
}

TEST(ReferenceModel, ACancelEndsFeatureExtraction) {
  ReferenceModelOptions options;
  options.cancel = geometry::CancelCheck{[] { return true; }};
  EXPECT_THROW(load_reference_model(fs::path(CMMD_SOURCE_DIR) / "config" / "samples" / "case3_block.ply", box, options),
               geometry::Cancelled);
}

}  // namespace
}  // namespace cmm::planner
