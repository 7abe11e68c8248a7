// The deviation map's rasterizer and colours, on the image buffer itself: a shaded part on the
// background, discs where visible points are, none for points behind the part, and the colour
// scales (red only outside a tolerance, grey for not measured).
#include <gtest/gtest.h>

#include <cmath>

#include "geometry/analytic_parts.hpp"
#include "planner/deviation_colours.hpp"
#include "planner/deviation_map.hpp"

namespace cmm::planner {
namespace {

using geometry::Vec3;

int count_not(const RgbImage& image, Rgb colour) {
  int n = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) n += image.at(x, y) != colour;
  }
  return n;
}

TEST(DeviationMap, DrawsTheShadedPartAndTheVisiblePoints) {
  const geometry::AnalyticPart cube = geometry::make_cube(40, 4.0);  // [0, 40]³
  const Rgb red = tolerance_colour(0.3, {-0.1, 0.1});
  ASSERT_EQ(red, outside_colour());
  const std::vector<MapPoint> points{
      {Vec3(20, 0, 40), red, 5},                     // top front edge: in view from above the front
      {Vec3(20, 40, 0), {0, 0, 255}, 5},             // bottom back edge: behind the part
      {Vec3(40, 20, 40), relative_colour(0), 5},     // top right edge: in view
  };
  const DeviationMap map = render_deviation_map(&cube.mesh, points);
  ASSERT_EQ(map.image.width, 900);
  ASSERT_EQ(map.image.height, 600);
  ASSERT_EQ(map.points.size(), 3u);

  // The part covers a good share of the picture, in greys of more than one shade (top vs sides).
  const int covered = count_not(map.image, {255, 255, 255});
  EXPECT_GT(covered, 900 * 600 / 10);
  const Rgb top = map.image.at(map.points[0].x, map.points[0].y - 40);    // just behind the front edge, on top
  const Rgb front = map.image.at(map.points[0].x, map.points[0].y + 40);  // just below it, on the front face
  EXPECT_EQ(top.r, top.g);
  EXPECT_EQ(front.r, front.b);
  EXPECT_NE(top, front);
  EXPECT_NE(top, (Rgb{255, 255, 255}));

  EXPECT_TRUE(map.points[0].visible);
  EXPECT_EQ(map.image.at(map.points[0].x, map.points[0].y), red);
  EXPECT_FALSE(map.points[1].visible);
  EXPECT_TRUE(map.points[2].visible);
  EXPECT_EQ(map.visible, 2);
  for (int y = 0; y < map.image.height; ++y) {
    for (int x = 0; x < map.image.width; ++x) ASSERT_NE(map.image.at(x, y), (Rgb{0, 0, 255})) << x << "," << y;
  }

  // Without the mesh nothing hides a point, and only the discs differ from the background.
  const DeviationMap bare = render_deviation_map(nullptr, points);
  EXPECT_EQ(bare.visible, 3);
  EXPECT_EQ(bare.image.at(bare.points[1].x, bare.points[1].y), (Rgb{0, 0, 255}));
  EXPECT_LT(count_not(bare.image, {255, 255, 255}), 3 * 130);
}

TEST(DeviationMap, SurvivesBrokenInput) {
  geometry::TriangleMesh mesh = geometry::make_cube(40, 8.0).mesh;
  mesh.vertices(0, 0) = std::nan("");
  mesh.vertices(1, 2) = 1e300;
  mesh.faces(0, 1) = 1 << 30;  // no such vertex
  const std::vector<MapPoint> points{{Vec3(std::nan(""), 0, 0), outside_colour(), 4},
                                     {Vec3(1e300, 0, 0), outside_colour(), 4},
                                     {Vec3(20, 0, 40), tolerance_colour(std::nan(""), {-0.1, 0.1}), 4}};
  const DeviationMap map = render_deviation_map(&mesh, points);
  EXPECT_FALSE(map.points[0].visible);
  EXPECT_EQ(points[2].colour, not_measured_colour());
  EXPECT_GT(count_not(map.image, {255, 255, 255}), 0);
}

TEST(DeviationMap, RefusesAnEmptySize) {
  EXPECT_THROW(render_deviation_map(nullptr, {}, {.width = 0}), std::invalid_argument);
}

TEST(DeviationColours, ToleranceScaleIsRedOnlyOutside) {
  const ToleranceZone zone{-0.1, 0.1};
  EXPECT_EQ(tolerance_colour(0.1001, zone), outside_colour());
  EXPECT_EQ(tolerance_colour(-0.1001, zone), outside_colour());
  EXPECT_EQ(tolerance_colour(0, zone), relative_colour(0));
  const Rgb green = relative_colour(0), upper = tolerance_colour(0.1, zone), lower = tolerance_colour(-0.1, zone);
  EXPECT_GT(green.g, green.r);
  EXPECT_GT(upper.r, upper.b);  // orange toward the upper limit
  EXPECT_GT(lower.b, lower.r);  // blue toward the lower
  EXPECT_NE(upper, outside_colour());
  EXPECT_DOUBLE_EQ(relative_deviation(0.05, {-0.2, 0.1}), 0.5);
  EXPECT_DOUBLE_EQ(relative_deviation(-0.05, {-0.2, 0.1}), -0.25);
  EXPECT_TRUE(std::isinf(relative_deviation(-0.01, {0, 0.1})));
  // Nothing fails against the scan: its scale saturates, never red.
  EXPECT_EQ(scan_colour(10), relative_colour(1));
  EXPECT_EQ(scan_colour(-10), relative_colour(-1));
  EXPECT_EQ(css_colour({255, 8, 16}), "#ff0810");
}

TEST(DeviationColours, MapPointsPutFailuresOnTopAndGreyForNotMeasured) {
  MeasurementResult result;
  for (int id = 0; id < 3; ++id) {
    EdgeResult e;
    e.id = id;
    e.reference = Vec3(id, 0, 0);
    e.status = id == 2 ? FeatureStatus::not_planned : FeatureStatus::measured;
    if (id != 2) {
      e.scan.emplace();
      e.scan->frame = PointFrame::scan;
      e.scan->position = Vec3(id, 1, 0);
    }
    result.edges.push_back(e);
  }
  InspectionResult inspection;
  inspection.edges.resize(3);
  for (int id = 0; id < 3; ++id) inspection.edges[id].id = id;
  inspection.edges[0].profile = {.deviation_mm = 0.5, .uncertainty_mm = 0.01, .zone = {-0.1, 0.1}, .verdict = Verdict::fail};
  inspection.edges[1].profile = {.deviation_mm = 0.01, .uncertainty_mm = 0.01, .zone = {-0.1, 0.1}, .verdict = Verdict::pass};
  inspection.edges[2].reason = "not measured";
  result.inspection = inspection;
  const std::vector<MapPoint> points = deviation_map_points(result);
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points[0].colour, not_measured_colour());
  EXPECT_EQ(points[0].position, Vec3(2, 0, 0));  // at its reference: it has no measured position
  EXPECT_EQ(points[1].position, Vec3(1, 1, 0));
  EXPECT_EQ(points[2].colour, outside_colour());
  EXPECT_EQ(points[2].position, Vec3(0, 1, 0));
}

}  // namespace
}  // namespace cmm::planner
