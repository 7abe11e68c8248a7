// Resampling and the turn of a polyline: the turn is what side normals along a rim are corrected by,
// so it must be the circle's curvature about its axis, and nothing on straight runs or at corners.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "geometry/polyline_sampling.hpp"

namespace cmm::geometry {
namespace {

std::vector<Vec3> circle(double radius, int vertices) {
  std::vector<Vec3> points;
  for (int k = 0; k < vertices; ++k) {
    const double a = 2 * std::numbers::pi * k / vertices;
    points.emplace_back(radius * std::cos(a), radius * std::sin(a), 5);
  }
  return points;
}

TEST(PolylineSampling, SamplesAreEvenAndOnTheCurve) {
  const std::vector<Vec3> points = circle(25, 400);
  const auto samples = sample_polyline(points, true, 2.0);
  ASSERT_EQ(samples.size(), 79u);  // ⌈157.08 / 2⌉
  for (const PolylineSample& s : samples) {
    EXPECT_NEAR(std::hypot(s.position.x(), s.position.y()), 25, 1e-3);
    EXPECT_NEAR(s.direction.norm(), 1, 1e-12);
  }
}

TEST(PolylineSampling, TurnOfACircleIsItsCurvatureAboutItsAxis) {
  const std::vector<Vec3> points = circle(25, 400);
  for (const PolylineSample& s : sample_polyline(points, true, 7.0)) {
    const Vec3 turn = polyline_turn(points, true, s, 10);
    EXPECT_NEAR(turn.norm(), 1 / 25.0, 1e-4);  // counter-clockwise seen from +z: about +z
    EXPECT_NEAR(turn.normalized().z(), 1, 1e-9);
  }
  // Traversed the other way it turns about −z.
  std::vector<Vec3> reversed(points.rbegin(), points.rend());
  const auto samples = sample_polyline(reversed, true, 7.0);
  EXPECT_NEAR(polyline_turn(reversed, true, samples[3], 10).z(), -1 / 25.0, 1e-4);
}

TEST(PolylineSampling, NoTurnOnAStraightRunOrNearACorner) {
  // An L: 30 mm along x, then 30 mm along y.
  std::vector<Vec3> points;
  for (int k = 0; k <= 30; ++k) points.emplace_back(k, 0, 0);
  for (int k = 1; k <= 30; ++k) points.emplace_back(30, k, 0);
  for (const PolylineSample& s : sample_polyline(points, false, 1.0)) {
    const Vec3 turn = polyline_turn(points, false, s, 6);
    const double to_corner = (s.position - Vec3(30, 0, 0)).norm();
    // Far from the corner the run is straight; near it the full and half spans disagree.
    EXPECT_EQ(turn.norm(), 0) << "at " << s.position.transpose() << ", " << to_corner << " from the corner";
  }
}

}  // namespace
}  // namespace cmm::geometry
