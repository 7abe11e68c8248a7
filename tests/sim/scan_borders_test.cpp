// The seen region's borders that the scan-front-end tests hold a scan's mesh to.
#include "sim/scan_borders.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "geometry/analytic_parts.hpp"

namespace cmm::sim {
namespace {

// The case-3 block seen from above and around: its underside (one outer border along the bottom
// edges), the Ø42 through bore's lower rim, and where each Ø10 bore's wall falls into shadow.
TEST(ScanBorders, Case3BlockSeenFromAboveAndAround) {
  const auto part = geometry::make_analytic_part("case3_block", 2.0);
  const std::vector<ScanBorder> borders = scan_borders(part.mesh, default_views());
  ASSERT_EQ(borders.size(), 6u);
  int outer = 0, big = 0, small = 0;
  for (const ScanBorder& b : borders) {
    if (b.kind == geometry::LoopKind::outer) {
      ++outer;
      EXPECT_NEAR(b.perimeter_mm, 2 * (88 + 95), 1e-6);
      EXPECT_NEAR(b.centre.z(), 0, 1e-9);
    } else if (b.perimeter_mm > 100) {
      ++big;
      EXPECT_NEAR(b.perimeter_mm, M_PI * 42, 0.5);  // the rim at the bottom of the through bore
      EXPECT_NEAR(b.centre.z(), 0, 1e-9);
    } else {
      ++small;
      EXPECT_GT(b.centre.z(), 0);  // inside the bore, above its bottom mouth
      EXPECT_LT(b.centre.z(), 41);
    }
  }
  EXPECT_EQ(outer, 1);
  EXPECT_EQ(big, 1);
  EXPECT_EQ(small, 4);
}

TEST(ScanBorders, CubeSeenFromEverySideButBelowHasOneBorder) {
  const auto part = geometry::make_analytic_part("cube", 2.0);
  const std::vector<ScanBorder> borders = scan_borders(part.mesh, default_views());
  ASSERT_EQ(borders.size(), 1u);
  EXPECT_EQ(borders[0].kind, geometry::LoopKind::outer);
  EXPECT_NEAR(borders[0].perimeter_mm, 4 * 40, 1e-6);  // the side walls' lower edges
  EXPECT_NEAR(borders[0].centre.z(), 0, 1e-9);
}

// The small openings stay openings: each through hole and the slot has one border (where its wall
// falls into shadow, or its lower rim), besides the underside's outer one.
TEST(ScanBorders, PlateSmallOpeningsHasABorderPerOpening) {
  const auto part = geometry::make_analytic_part("plate_small_openings", 2.0);
  const std::vector<ScanBorder> borders = scan_borders(part.mesh, default_views());
  int outer = 0, slot = 0, small_hole = 0;
  for (const ScanBorder& b : borders) {
    if (b.kind == geometry::LoopKind::outer) {
      ++outer;
      EXPECT_NEAR(b.perimeter_mm, 2 * (120 + 80), 1e-6);
      continue;
    }
    slot += std::abs(b.centre.x() - 40) < 1 && std::abs(b.centre.y() - 10) < 1;
    small_hole += std::hypot(b.centre.x() - 10, b.centre.y() - 70) < 1;
  }
  EXPECT_EQ(borders.size(), 8u);
  EXPECT_EQ(outer, 1);
  EXPECT_EQ(slot, 1);
  EXPECT_EQ(small_hole, 1);
}

// What the scan shows of an opening is its mouth, however far the unseen region runs on through it: the
// slot's is 1 mm in half-width and the Ø3 hole's 1.5 mm, seen down z, though their borders run down
// the walls at varying depth (a loop's vector area tilts 25° there).
TEST(ScanBorders, AnOpeningsMouthIsAsWideAsTheOpening) {
  const auto part = geometry::make_analytic_part("plate_small_openings", 0.5);
  int checked = 0;
  for (const ScanBorder& b : scan_borders(part.mesh, default_views())) {
    if (b.kind == geometry::LoopKind::outer) {
      EXPECT_EQ(b.mouth_half_width_mm, 0);
      continue;
    }
    EXPECT_NEAR(std::abs(b.mouth_axis.z()), 1, 1e-3);
    EXPECT_GT(b.unseen_half_width_mm, 5);  // down the walls and over the underside
    if (std::abs(b.centre.x() - 40) < 1 && std::abs(b.centre.y() - 10) < 1) {
      EXPECT_NEAR(b.mouth_half_width_mm, 1.0, 0.03);
      ++checked;
    }
    if (std::hypot(b.centre.x() - 10, b.centre.y() - 70) < 1) {
      EXPECT_NEAR(b.mouth_half_width_mm, 1.5, 0.03);  // a 20-gon's inscribed circle: 1.48
      ++checked;
    }
  }
  EXPECT_EQ(checked, 2);
}

// A partial view's border runs along its band's edge: from above, half the cube's top face.
TEST(ScanBorders, CoverageBandsCutTheSeenRegion) {
  const auto part = geometry::make_analytic_part("cube", 2.0);
  const std::vector<ScanView> above{{geometry::Vec3(0, 0, -1)}};
  ASSERT_EQ(scan_borders(part.mesh, above).size(), 1u);
  const ScanBorder top = scan_borders(part.mesh, above)[0];
  EXPECT_NEAR(top.perimeter_mm, 4 * 40, 1e-6);
  // Its corners in order: the polyline through them is the border, as long as it.
  double length = 0;
  for (std::size_t i = 0; i < top.points.size(); ++i) {
    length += (top.points[(i + 1) % top.points.size()] - top.points[i]).norm();
    EXPECT_NEAR(top.points[i].z(), 40, 1e-9);
  }
  EXPECT_NEAR(length, 4 * 40, 1e-6);
  const ScanVisibility visibility(part.mesh);
  const std::vector<CoverageBand> half = coverage_bands(visibility, above, 0.5, CoverageMeasure::surface_area, 3);
  const std::vector<ScanBorder> borders = scan_borders(part.mesh, above, kDefaultMaxIncidenceDeg, half);
  ASSERT_EQ(borders.size(), 1u);
  EXPECT_EQ(borders[0].kind, geometry::LoopKind::outer);
  EXPECT_NEAR(borders[0].centre.z(), 40, 1e-9);
  // Half a square cut through its middle: 120 mm round when cut along a side, 137 mm across the diagonal;
  // the mesh's edges step along the cut.
  EXPECT_GT(borders[0].perimeter_mm, 110);
  EXPECT_LT(borders[0].perimeter_mm, 160);
}

}  // namespace
}  // namespace cmm::sim
