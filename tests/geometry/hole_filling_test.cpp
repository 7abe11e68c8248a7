// Gap or opening along a crease: a 1 mm strip the growth left between a face and a right-angled crease,
// 38 mm long (longer than any loop a patch is guessed for), is closed in the side face when the raw scan
// lies across it. A 2 mm strip with nothing scanned across it is a real opening (wider than
// 2·max(1.5 B, r*), docs/scan.md) and stays open, long or short.
#include <gtest/gtest.h>

#include <cmath>

#include "geometry/boundary_loops.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/hole_filling.hpp"

namespace cmm::geometry {
namespace {

constexpr double kStep = 0.5;  // the grid's spacing, mm: also the bin B

// The top face z = 0 (x from −10 to 0) folded down into the side face x = 0 (z from 0 to −10), y from
// 0 to 40, one grid; the side face's facets above z = −width are missing for 1 < y < 1 + length.
struct Strip {
  double width = 1, length = 38;
  double from = 0;  // where the strip starts across the fold: below 0 it takes in part of the top face
  bool inside(double u, double y) const { return u > from && u < from + width && y > 1 && y < 1 + length; }
};

TriangleMesh folded_sheet_with_a(const Strip& strip) {
  const int across = 40, along = 80;  // 20 mm unfolded across, 40 mm along
  TriangleMesh mesh;
  mesh.vertices.resize((across + 1) * (along + 1), 3);
  const auto id = [&](int i, int j) { return i * (along + 1) + j; };
  for (int i = 0; i <= across; ++i)
    for (int j = 0; j <= along; ++j) {
      const double u = i * kStep - 10;  // < 0: top face, > 0: down the side
      mesh.vertices.row(id(i, j)) << std::min(u, 0.0), j * kStep, -std::max(u, 0.0);
    }
  std::vector<std::array<int, 3>> faces;
  for (int i = 0; i < across; ++i)
    for (int j = 0; j < along; ++j) {
      const double u = (i + 0.5) * kStep - 10, y = (j + 0.5) * kStep;
      if (strip.inside(u, y)) continue;
      faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  mesh.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int k = 0; k < 3; ++k) mesh.faces(static_cast<Eigen::Index>(f), k) = faces[f][static_cast<std::size_t>(k)];
  return mesh;
}

// Raw points every 0.2 mm on the top face and every `side_step` on the side (a face one view saw at a
// grazing angle); without `across_the_strip`, none where the strip is.
Points raw_scan(const Strip& strip, bool across_the_strip, double side_step = 0.2) {
  std::vector<Vec3> points;
  const auto add = [&](double u, double y) {
    if (!across_the_strip && strip.inside(u - 0.05, y) && strip.inside(u + 0.05, y)) return;
    points.emplace_back(std::min(u, 0.0), y, -std::max(u, 0.0));
  };
  for (double u = -10; u <= 1e-9; u += 0.2)
    for (double y = 0; y <= 40; y += 0.2) add(u, y);
  for (double u = side_step; u <= 10; u += side_step)
    for (double y = 0; y <= 40; y += side_step) add(u, y);
  Points raw(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t i = 0; i < points.size(); ++i) raw.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
  return raw;
}

std::size_t loops(const TriangleMesh& mesh) { return boundary_loops(mesh, edge_adjacency(mesh)).size(); }

HoleFillingOptions options() {
  HoleFillingOptions o;
  o.bin_mm = kStep;
  return o;
}

TEST(HoleFilling, AThinStripAlongACreaseWithTheScanAcrossItClosesInTheFace) {
  const Strip strip;
  TriangleMesh mesh = folded_sheet_with_a(strip);
  ASSERT_EQ(loops(mesh), 2u);
  const Points raw = raw_scan(strip, true);
  const CloudIndex index(raw);
  const HoleFilling filled = fill_false_holes(mesh, raw, index, options());
  EXPECT_EQ(filled.loops_filled, 1u);
  EXPECT_EQ(loops(mesh), 1u);
  // Every facet lies in one of the two faces: the crease stays sharp.
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Vec3 c = (vertex(mesh, mesh.faces(f, 0)) + vertex(mesh, mesh.faces(f, 1)) + vertex(mesh, mesh.faces(f, 2))) / 3;
    EXPECT_LT(std::min(std::abs(c.z()), std::abs(c.x())), 1e-9) << "facet " << f;
  }
}

// A notch across the fold, 1.5 mm into the top face and 1 mm down the side, 3 mm long, where the side
// was scanned every 1.5 mm (its own sampling leaves points 1.06 mm from the nearest, wider than 1.5 B)
// and the top every 0.2 mm. Most of the loop's vertices lie by the dense top: at the density of the
// loop's median vertex the side's voids (0.91 mm on the patch) read as an opening (r* 0.50 mm), at
// that of its sparser quarter (r* 1.05 mm) as the gaps they are.
TEST(HoleFilling, AGapBesideAFaceScannedSparselyClosesAtThatFacesDensity) {
  const Strip strip{2.5, 3, -1.5};
  TriangleMesh mesh = folded_sheet_with_a(strip);
  ASSERT_EQ(loops(mesh), 2u);
  const Points raw = raw_scan(strip, true, 1.5);
  const CloudIndex index(raw);
  const HoleFilling filled = fill_false_holes(mesh, raw, index, options());
  EXPECT_EQ(filled.loops_filled, 1u);
  EXPECT_EQ(loops(mesh), 1u);
}

// A gap 4 × 12 mm in the side face, which was scanned every 0.7 mm (half a point per bin B²): 32 mm
// round, longer than 60 B, and too wide for a thin strip. Such a face's own voids scale with its spacing
// (r* about 2.4 mm at its rim), and so does the longest loop worth a patch: with the scan across it the
// gap closes; an 8 mm opening with nothing scanned across it stays open.
TEST(HoleFilling, ALongGapInAFaceScannedSparselyClosesAndAWiderOpeningThereDoesNot) {
  for (const bool scanned_across : {true, false}) {
    const Strip strip{scanned_across ? 4.0 : 8.0, 12, 1.5};
    TriangleMesh mesh = folded_sheet_with_a(strip);
    ASSERT_EQ(loops(mesh), 2u);
    const Points raw = raw_scan(strip, scanned_across, 0.7);
    const CloudIndex index(raw);
    const HoleFilling filled = fill_false_holes(mesh, raw, index, options());
    EXPECT_EQ(filled.loops_filled, scanned_across ? 1u : 0u) << (scanned_across ? "the gap" : "the opening");
    EXPECT_EQ(loops(mesh), scanned_across ? 1u : 2u) << (scanned_across ? "the gap" : "the opening");
  }
}

TEST(HoleFilling, AWiderStripWithNothingScannedAcrossItStaysOpenLongOrShort) {
  for (const double length : {38.0, 8.0}) {
    const Strip strip{2, length};
    TriangleMesh mesh = folded_sheet_with_a(strip);
    const Points raw = raw_scan(strip, false);
    const CloudIndex index(raw);
    const HoleFilling filled = fill_false_holes(mesh, raw, index, options());
    EXPECT_EQ(filled.loops_filled, 0u) << "length " << length;
    EXPECT_EQ(loops(mesh), 2u) << "length " << length;
  }
}

}  // namespace
}  // namespace cmm::geometry
