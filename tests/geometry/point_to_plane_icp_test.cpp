// Point-to-plane ICP places a CAD export of few huge triangles onto a fine mesh of the same part that
// was moved, to a fraction of a micrometre, and refuses a start too far off.
#include "geometry/point_to_plane_icp.hpp"

#include <gtest/gtest.h>

#include <numbers>

#include "geometry/analytic_parts.hpp"

namespace cmm::geometry {
namespace {

TriangleMesh moved(TriangleMesh mesh, const Eigen::Isometry3d& T) {
  for (int v = 0; v < mesh.vertices.rows(); ++v) mesh.vertices.row(v) = (T * vertex(mesh, v)).transpose();
  return mesh;
}

TEST(PointToPlaneIcp, RecoversAMovedCaseThreeBlock) {
  const AnalyticPart cad = make_case3_block({Tessellation::Style::cad, 1.0, 0.002});
  const AnalyticPart fine = make_case3_block(0.5);
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = Eigen::AngleAxisd(1.5 * std::numbers::pi / 180, Vec3(0.2, 0.3, 1).normalized()).toRotationMatrix();
  truth.translation() = Vec3(0.8, -0.5, 0.3);
  const TriangleMesh target = moved(fine.mesh, truth);
  const IcpResult fit = point_to_plane_icp(cad.mesh, target);
  ASSERT_TRUE(fit.converged) << fit.iterations << " iterations, RMS " << fit.rms_mm;
  EXPECT_LT(fit.rms_mm, 0.003);
  EXPECT_GT(fit.overlap, 0.9);
  double worst = 0;
  for (int v = 0; v < cad.mesh.vertices.rows(); ++v)
    worst = std::max(worst, (fit.T_target_source * vertex(cad.mesh, v) - truth * vertex(cad.mesh, v)).norm());
  EXPECT_LT(worst, 0.0005) << "worst vertex off by " << worst << " mm";
}

TEST(PointToPlaneIcp, RecoversACaseThreeBlockTurnedByFifteenDegrees) {
  // Pairs whose normals differ by more than the gate are left out, so a start turned by most of it
  // must still find enough pairs to come round.
  const AnalyticPart cad = make_case3_block({Tessellation::Style::cad, 1.0, 0.002});
  const AnalyticPart fine = make_case3_block(0.5);
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = Eigen::AngleAxisd(15 * std::numbers::pi / 180, Vec3(0.1, 0.2, 1).normalized()).toRotationMatrix();
  const Vec3 centre = fine.mesh.vertices.colwise().mean().transpose();
  truth.translation() = centre - truth.linear() * centre;  // turned about the part's centre
  const IcpResult fit = point_to_plane_icp(cad.mesh, moved(fine.mesh, truth));
  ASSERT_TRUE(fit.converged) << fit.iterations << " iterations, RMS " << fit.rms_mm;
  double worst = 0;
  for (int v = 0; v < cad.mesh.vertices.rows(); ++v)
    worst = std::max(worst, (fit.T_target_source * vertex(cad.mesh, v) - truth * vertex(cad.mesh, v)).norm());
  EXPECT_LT(worst, 0.0005) << "worst vertex off by " << worst << " mm";
}

TEST(PointToPlaneIcp, RefusesAStartWithNothingInReach) {
  const AnalyticPart cube = make_cube(10, 1.0);
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() = Vec3(100, 0, 0);
  EXPECT_THROW(point_to_plane_icp(cube.mesh, cube.mesh, far), std::invalid_argument);
  EXPECT_THROW(point_to_plane_icp(TriangleMesh{}, cube.mesh), std::invalid_argument);
}

}  // namespace
}  // namespace cmm::geometry
