// The nominal a job names: read from the model store, refused with a clear error when it is a cloud
// or given in another frame, fitted by ICP when asked.
#include "daemon/job_inspection.hpp"

#include <fstream>

#include <gtest/gtest.h>

#include "daemon/client/rpc_error.hpp"
#include "fresh_folder.hpp"
#include "geometry/box_with_holes_mesher.hpp"
#include "geometry/ply_io.hpp"

namespace cmm::daemon {
namespace {

// A 100 × 60 × 20 mm block as a CAD export has it (twelve triangles), corner at `origin`, faces
// counter-clockwise seen from outside.
geometry::TriangleMesh block(const Eigen::RowVector3d& origin) {
  geometry::TriangleMesh m;
  m.vertices.resize(8, 3);
  for (int i = 0; i < 8; ++i)
    m.vertices.row(i) = origin + Eigen::RowVector3d(i & 1 ? 100 : 0, i & 2 ? 60 : 0, i & 4 ? 20 : 0);
  m.faces.resize(12, 3);
  m.faces << 0, 2, 1, 1, 2, 3,  // bottom (−z)
      4, 5, 6, 5, 7, 6,         // top (+z)
      0, 1, 4, 1, 5, 4,         // −y
      2, 6, 3, 3, 6, 7,         // +y
      0, 4, 2, 2, 4, 6,         // −x
      1, 3, 5, 3, 7, 5;         // +x
  return m;
}

class JobInspection : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fresh_folder("job-inspection");
    std::filesystem::create_directories(dir_ / "files");
    store_.emplace(dir_ / "models", dir_ / "files");
    // The reference is a scan's mesh: dense, as the ICP's planes need.
    reference_.mesh = geometry::mesh_box_with_holes({100, 60, 20}, {}, 2.0);
  }

  std::string put(const std::string& name, const geometry::TriangleMesh& mesh) {
    std::ofstream out(dir_ / "files" / name, std::ios::binary);
    geometry::write_ply(out, mesh);
    return "file:" + name;
  }

  JobRequest request_for(const std::string& model, const std::string& placement) const {
    JobRequest r;
    r.nominal = NominalRequest{model, 1, placement};
    return r;
  }

  // The RpcError inspect_job throws for `model`, or a failure when it throws none.
  RpcError refusal(const std::string& model, const std::string& placement = "given") {
    try {
      (void)inspect_job(request_for(model, placement), *store_, reference_, {});
    } catch (const RpcError& e) {
      return e;
    }
    ADD_FAILURE() << model << " was accepted";
    return RpcError(0, "");
  }

  std::filesystem::path dir_;
  std::optional<ModelStore> store_;
  ReferenceModel reference_;
};

TEST_F(JobInspection, WithoutANominalThereIsNothingToInspect) {
  EXPECT_FALSE(inspect_job(JobRequest{}, *store_, reference_, {}));
}

TEST_F(JobInspection, ACloudIsRefusedAsANominal) {
  geometry::TriangleMesh cloud = block(Eigen::RowVector3d::Zero());
  cloud.faces.resize(0, 3);
  const RpcError e = refusal(put("cloud.ply", cloud));
  EXPECT_EQ(e.code(), rpc_code::model_error);
  EXPECT_NE(std::string(e.what()).find("holds a point cloud"), std::string::npos) << e.what();
  EXPECT_EQ(e.data().at("kind"), "nominal");
}

TEST_F(JobInspection, ANominalGivenInAnotherFrameIsRefusedWithHowFarItIs) {
  // The CAD export's own origin, a metre away: every point would find no nominal edge.
  const RpcError e = refusal(put("far.ply", block(Eigen::RowVector3d(1000, 0, 0))));
  EXPECT_EQ(e.code(), rpc_code::model_error);
  EXPECT_NE(std::string(e.what()).find("lies 900 mm from the reference"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("\"placement\": \"fit\""), std::string::npos) << e.what();
}

TEST_F(JobInspection, ANominalInTheReferencesFrameIsUsedAsGiven) {
  const auto inspection = inspect_job(request_for(put("same.ply", block(Eigen::RowVector3d(0.5, 0, 0))), "given"), *store_,
                                      reference_, {});
  ASSERT_TRUE(inspection);
  EXPECT_EQ(inspection->nominal.method, "given");
  EXPECT_TRUE(inspection->nominal.T_S_N.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_EQ(inspection->verdict, planner::Verdict::incomplete) << "no feature was measured: no pass by omission";
}

TEST_F(JobInspection, AFarNominalIsFittedOntoTheReferenceWhenAskedTo) {
  const auto inspection = inspect_job(request_for(put("far.ply", block(Eigen::RowVector3d(1000, -40, 7))), "fit"), *store_,
                                      reference_, {});
  ASSERT_TRUE(inspection);
  EXPECT_EQ(inspection->nominal.method, "icp");
  EXPECT_TRUE(inspection->nominal.converged);
  EXPECT_LT((inspection->nominal.T_S_N.translation() - Eigen::Vector3d(-1000, 40, -7)).norm(), 1e-6);
  EXPECT_LT(inspection->nominal.rms_mm, 1e-6);
}

}  // namespace
}  // namespace cmm::daemon
