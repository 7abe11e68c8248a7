// The least-folding patch: flat loops give flat patches wound against the loop, a strip along a crease
// gets facets in its faces, a loop whose projection crosses itself still gets a patch, forbidden
// diagonals are never made, and an outline's patch shows as folding onto its rim.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "geometry/least_folding_patch.hpp"

namespace cmm::geometry {
namespace {

const auto anything = [](int, int) { return true; };

Vec3 facet_normal(const std::vector<Vec3>& loop, const std::array<int, 3>& t) {
  return (loop[static_cast<std::size_t>(t[1])] - loop[static_cast<std::size_t>(t[0])])
      .cross(loop[static_cast<std::size_t>(t[2])] - loop[static_cast<std::size_t>(t[0])])
      .normalized();
}

// Each loop side i → i + 1 appears reversed in exactly one triangle.
void expect_closes(const std::vector<Vec3>& loop, const LeastFoldingPatch& patch) {
  const int n = static_cast<int>(loop.size());
  ASSERT_EQ(patch.triangles.size(), loop.size() - 2);
  for (int i = 0; i < n; ++i) {
    const int a = i, b = (i + 1) % n;
    int held = 0;
    for (const auto& t : patch.triangles)
      for (int k = 0; k < 3; ++k) held += t[static_cast<std::size_t>(k)] == b && t[static_cast<std::size_t>((k + 1) % 3)] == a;
    EXPECT_EQ(held, 1) << "side " << a << " -> " << b;
  }
}

// A hole in a z-up surface: the surface lies left of the loop, so the loop runs clockwise seen from above.
std::vector<Vec3> clockwise_square() { return {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}}; }

TEST(LeastFoldingPatch, AFlatHoleGetsAFlatPatchFacingLikeItsRim) {
  const std::vector<Vec3> loop = clockwise_square();
  const std::vector<Vec3> rim(loop.size(), Vec3::UnitZ());
  const auto patch = least_folding_patch(loop, rim, anything);
  ASSERT_TRUE(patch);
  expect_closes(loop, *patch);
  EXPECT_NEAR(patch->max_dihedral_rad, 0, 1e-9);
  EXPECT_NEAR(patch->area, 1, 1e-12);
  for (const auto& t : patch->triangles) EXPECT_GT(facet_normal(loop, t).z(), 0.999);
}

// A strip between a crease line (the top face z = 0, x ≤ 0, meets the side face x = 0, z ≤ 0) and a
// ragged row on the side face at z ≈ −1: the patch lies in the side face, turning the crease's 90°
// against the top face only.
TEST(LeastFoldingPatch, AStripBesideACreaseLiesInItsFace) {
  std::vector<Vec3> loop;
  std::vector<Vec3> rim;
  // Along the crease (rim: top facets, normal +z), then back along the side row (rim: side facets, +x).
  for (int i = 0; i <= 6; ++i) loop.emplace_back(0, i, 0), rim.push_back(Vec3::UnitZ());
  for (int i = 6; i >= 0; --i) loop.emplace_back(0, i + 0.3 * (i % 2), -1 + 0.4 * (i % 3 == 1)), rim.push_back(Vec3::UnitX());
  rim[6] = Vec3::UnitX();  // the side from the crease's end down to the row borders a side facet
  const auto patch = least_folding_patch(loop, rim, anything);
  ASSERT_TRUE(patch);
  expect_closes(loop, *patch);
  EXPECT_NEAR(patch->max_dihedral_rad, std::numbers::pi / 2, 1e-9);
  for (const auto& t : patch->triangles) EXPECT_GT(facet_normal(loop, t).x(), 0.999);
}

// A loop with a spike doubling back over its own side: seen along its normal it crosses itself, so no
// ear clipping takes it; the patch still closes it, nearly flat.
TEST(LeastFoldingPatch, ALoopThatCrossesItselfInEveryProjectionStillCloses) {
  // The last side crosses the one before last but one at (1, 0.5) seen from above.
  std::vector<Vec3> loop = {{0, 0, 0}, {0, 3, 0}, {1, 3, 0}, {1, 1.2, 0}, {1, 0.4, 0.01}, {0.95, 1.0, 0.02}, {1.05, 0, 0}};
  const std::vector<Vec3> rim(loop.size(), Vec3::UnitZ());
  const auto patch = least_folding_patch(loop, rim, anything);
  ASSERT_TRUE(patch);
  expect_closes(loop, *patch);
  EXPECT_LT(patch->max_dihedral_rad, 0.5 * std::numbers::pi);
}

TEST(LeastFoldingPatch, ForbiddenDiagonalsAreNeverMade) {
  const std::vector<Vec3> loop = clockwise_square();
  const std::vector<Vec3> rim(loop.size(), Vec3::UnitZ());
  // Only 0–2 allowed: the patch must use it.
  const auto patch = least_folding_patch(loop, rim, [](int a, int b) { return (a == 0 && b == 2) || (a == 2 && b == 0); });
  ASSERT_TRUE(patch);
  for (const auto& t : patch->triangles) {
    bool has0 = false, has2 = false;
    for (int v : t) has0 |= v == 0, has2 |= v == 2;
    EXPECT_TRUE(has0 && has2);
  }
  EXPECT_FALSE(least_folding_patch(loop, rim, [](int, int) { return false; }));
  EXPECT_FALSE(least_folding_patch({{0, 0, 0}, {1, 0, 0}}, {Vec3::UnitZ(), Vec3::UnitZ()}, anything));
  EXPECT_FALSE(least_folding_patch({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, std::vector<Vec3>(3, Vec3::UnitZ()), anything));
}

// The outline of a z-up patch runs counter-clockwise seen from above: its "patch" would face down, a
// second sheet folded onto the surface.
TEST(LeastFoldingPatch, AnOutlinesPatchFoldsOntoItsRim) {
  std::vector<Vec3> loop = clockwise_square();
  std::reverse(loop.begin(), loop.end());
  const auto patch = least_folding_patch(loop, std::vector<Vec3>(loop.size(), Vec3::UnitZ()), anything);
  ASSERT_TRUE(patch);
  EXPECT_NEAR(patch->max_dihedral_rad, std::numbers::pi, 1e-9);
}

}  // namespace
}  // namespace cmm::geometry
