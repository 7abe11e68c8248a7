// The trapezoidal move time against its closed forms, and the metric properties the ordering and
// the spanning-tree bound rely on.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "planner/motion_time.hpp"

namespace {

using cmm::planner::trapezoid_time;
using cmm::planner::TravelCost;

// v = 100 mm/s, a = 500 mm/s²: full speed is reached after 10 mm, so moves up to 20 mm are triangular.
constexpr double v = 100, a = 500;

TEST(TrapezoidTime, ShortMovesAreTriangular) {
  EXPECT_DOUBLE_EQ(trapezoid_time(0, v, a), 0);
  EXPECT_DOUBLE_EQ(trapezoid_time(5, v, a), 2 * std::sqrt(5 / a));  // 0.2 s
  EXPECT_DOUBLE_EQ(trapezoid_time(5, v, a), 0.2);
  EXPECT_DOUBLE_EQ(trapezoid_time(1e-6, v, a), 2 * std::sqrt(1e-6 / a));
}

TEST(TrapezoidTime, LongMovesCruise) {
  EXPECT_DOUBLE_EQ(trapezoid_time(120, v, a), 120 / v + v / a);  // 1.4 s
  EXPECT_DOUBLE_EQ(trapezoid_time(120, v, a), 1.4);
  EXPECT_DOUBLE_EQ(trapezoid_time(1e4, v, a), 100.2);
}

TEST(TrapezoidTime, BothProfilesMeetAtTheSwitchDistance) {
  const double switch_distance = v * v / a;  // 20 mm
  EXPECT_DOUBLE_EQ(trapezoid_time(switch_distance, v, a), 2 * v / a);
  EXPECT_NEAR(trapezoid_time(switch_distance * (1 - 1e-12), v, a), 2 * v / a, 1e-9);
  EXPECT_NEAR(trapezoid_time(switch_distance * (1 + 1e-12), v, a), 2 * v / a, 1e-9);
}

TEST(TrapezoidTime, InfiniteAccelerationIsConstantSpeed) {
  EXPECT_DOUBLE_EQ(trapezoid_time(50, v, std::numeric_limits<double>::infinity()), 0.5);
}

TEST(TrapezoidTime, IncreasingAndConcave) {
  double previous = 0, previous_slope = std::numeric_limits<double>::infinity();
  for (double d = 0.25; d < 100; d += 0.25) {
    const double t = trapezoid_time(d, v, a);
    const double slope = (t - previous) / 0.25;
    EXPECT_GT(t, previous) << d;
    EXPECT_LE(slope, previous_slope * (1 + 1e-9)) << d;
    previous = t;
    previous_slope = slope;
  }
}

TEST(TrapezoidTime, TriangleInequalityOnPoints) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> coordinate(-60, 60);
  const TravelCost cost{v, a};
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector2d p(coordinate(random), coordinate(random)), q(coordinate(random), coordinate(random)),
        r(coordinate(random), coordinate(random));
    EXPECT_LE(cost(p, r), cost(p, q) + cost(q, r) + 1e-12);
  }
}

TEST(TrapezoidTime, RefusesNonsense) {
  EXPECT_THROW(trapezoid_time(-1, v, a), std::invalid_argument);
  EXPECT_THROW(trapezoid_time(std::nan(""), v, a), std::invalid_argument);
  EXPECT_THROW(trapezoid_time(std::numeric_limits<double>::infinity(), v, a), std::invalid_argument);
  EXPECT_THROW(trapezoid_time(1, 0, a), std::invalid_argument);
  EXPECT_THROW(trapezoid_time(1, v, -1), std::invalid_argument);
  EXPECT_THROW(trapezoid_time(1, v, std::nan("")), std::invalid_argument);
}

TEST(TravelCost, MeasuresStraightMovesIn2dAnd3d) {
  const TravelCost cost{v, a};
  EXPECT_DOUBLE_EQ(cost(Eigen::Vector2d(0, 0), Eigen::Vector2d(3, 4)), trapezoid_time(5, v, a));
  EXPECT_DOUBLE_EQ(cost(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, 120)), 1.4);
}

}  // namespace
