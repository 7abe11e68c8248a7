// Resampling, smoothing and the turn of a polyline: the turn is what side normals along a rim are
// corrected by, so it must be the circle's curvature about its axis, and nothing on straight runs or at
// corners; smoothing must take noise off a crease without moving it, and say what noise it leaves.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "geometry/circle_fit.hpp"

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

// RMS distance of points from the circle of radius R about +z at height 5, in its cross-section.
double rms_off_circle(const std::vector<Vec3>& points, double radius) {
  double sum = 0;
  for (const Vec3& p : points) sum += std::pow(std::hypot(p.x(), p.y()) - radius, 2) + std::pow(p.z() - 5, 2);
  return std::sqrt(sum / static_cast<double>(points.size()));
}

TEST(PolylineSampling, SmoothingSaysWhatNoiseItLeaves) {
  // A quadratic over 7 evenly spaced vertices keeps a third of the variance at the middle, more at an
  // open curve's end, where it reaches out to one side; unsmoothed vertices keep all of it.
  std::vector<Vec3> line;
  for (int k = 0; k <= 30; ++k) line.emplace_back(k, 0, 0);
  std::vector<double> gain;
  smooth_polyline(line, false, 3, &gain);
  EXPECT_NEAR(gain[15], 1.0 / 3, 1e-9);
  EXPECT_GT(gain[0], 0.75);
  EXPECT_GT(gain[0], gain[1]);
  smooth_polyline(line, false, 0, &gain);
  EXPECT_EQ(gain, std::vector<double>(line.size(), 1.0));
  // Vertices stacked on one spot (a hostile crease) leave nothing to fit: kept as they are, not NaN.
  const std::vector<Vec3> stacked(9, Vec3(1, 2, 3));
  const std::vector<Vec3> kept = smooth_polyline(stacked, true, 3, &gain);
  EXPECT_EQ(kept, stacked);
  EXPECT_EQ(gain, std::vector<double>(stacked.size(), 1.0));
}

TEST(PolylineSampling, ARimIsSmoothedByAngleWithoutCuttingItsCorner) {
  // A Ø6 rim cut into 19 vertices, as a noisy scan's bore: by arc length a window of ±4 vertices spans
  // 150° and pulls the rim in by 43 µm RMS; by angle about its fitted circle the radius stays.
  const std::vector<Vec3> exact = circle(3, 19);
  EXPECT_GT(rms_off_circle(smooth_polyline(exact, true, 4), 3), 0.03);
  std::vector<double> gain;
  const std::vector<Vec3> kept = smooth_rim(exact, fit_circle(exact), 4, &gain);
  EXPECT_LT(rms_off_circle(kept, 3), 1e-9);
  EXPECT_NEAR(gain[0], gain[9], 1e-12);
  EXPECT_LT(gain[0], 1.0 / 3);

  // With noise of σ 0.1 mm on a Ø50 rim, what is left matches what the gain says.
  std::vector<Vec3> noisy = circle(25, 150);
  std::mt19937_64 rng(15);
  std::normal_distribution<double> noise(0, 0.1);
  for (Vec3& p : noisy) p += Vec3(noise(rng), noise(rng), noise(rng));
  const std::vector<Vec3> smoothed = smooth_rim(noisy, fit_circle(noisy), 7, &gain);
  const double expected = 0.1 * std::sqrt(2 * gain[0]);  // two components in the cross-section
  EXPECT_NEAR(rms_off_circle(smoothed, 25), expected, 0.3 * expected);
  EXPECT_LT(rms_off_circle(smoothed, 25), 0.6 * rms_off_circle(noisy, 25));
}

}  // namespace
}  // namespace cmm::geometry
