// The simulator's motion profile against closed forms, and consistency of its inverse and stops.
#include "sim/trapezoid_profile.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "planner/motion_time.hpp"

namespace cmm::sim {
namespace {

TEST(TrapezoidProfile, AgreesWithThePlannersClosedForm) {
  for (double d : {0.0, 0.01, 1.0, 39.9, 40.0, 40.1, 250.0, 1000.0}) {
    TrapezoidProfile p = make_profile(d, 200, 1000);
    EXPECT_NEAR(p.duration(), planner::trapezoid_time(d, 200, 1000), 1e-12) << d;
    EXPECT_NEAR(p.position_at(p.duration()), d, 1e-12);
  }
}

TEST(TrapezoidProfile, PositionAndTimeAreInverse) {
  for (double d : {5.0, 100.0}) {
    TrapezoidProfile p = make_profile(d, 50, 300);
    for (double s = 0; s <= d; s += d / 37) EXPECT_NEAR(p.position_at(p.time_at(s)), s, 1e-9) << d << " " << s;
    for (double t = 0; t <= p.duration(); t += p.duration() / 41) {
      EXPECT_GE(p.speed_at(t), 0);
      EXPECT_LE(p.speed_at(t), 50 + 1e-12);
    }
  }
}

TEST(TrapezoidProfile, StopsWithinTheBrakingDistance) {
  TrapezoidProfile p = make_profile(100, 50, 250);  // cruise at 50 after 0.2 s
  double t = 1.0;
  EXPECT_NEAR(p.stop_position(t), p.position_at(t) + 50.0 * 50.0 / 500, 1e-12);
  EXPECT_NEAR(p.stop_time(t), t + 0.2, 1e-12);
  EXPECT_NEAR(p.stop_position(p.duration()), 100, 1e-12);
}

TEST(TrapezoidProfile, PathLimitHonoursEachAxis) {
  Eigen::Vector3d u = Eigen::Vector3d(1, 1, 0).normalized();
  EXPECT_NEAR(path_limit(u, 200, Eigen::Vector3d(100, 300, 50)), 100 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(path_limit(Eigen::Vector3d::UnitZ(), 200, Eigen::Vector3d(100, 300, 50)), 50, 1e-12);
  EXPECT_THROW(make_profile(-1, 1, 1), std::invalid_argument);
  EXPECT_THROW(make_profile(1, 0, 1), std::invalid_argument);
}

}  // namespace
}  // namespace cmm::sim
