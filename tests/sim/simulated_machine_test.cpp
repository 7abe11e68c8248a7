// The simulated machine against its own truth: the plate (chamfer included) and the reference
// sphere are touched where they are, and the clock and the trigger noise behave as configured.
#include "sim/simulated_machine.hpp"

#include <cmath>

#include <gtest/gtest.h>

namespace cmm::sim {
namespace {

hal::ProbeMove search(const Vec3& start, const Vec3& direction, double travel = 10) {
  hal::ProbeMove p;
  p.start = start;
  p.direction = direction.normalized();
  p.max_travel_mm = travel;
  p.retract_mm = 1;
  p.min_travel_mm = 0.5;
  return p;
}

class SimulatedMachineTest : public ::testing::Test {
 protected:
  SimulatedMachine machine{sim_config_from_json({{"trigger_sigma_mm", 0}, {"part", {{"analytic", "cube"}}}})};
  void go(const Vec3& above) {
    const Vec3 at = machine.status().position;
    machine.move({Vec3(at.x(), at.y(), 80), 0});
    machine.move({Vec3(above.x(), above.y(), 80), 0});
  }
};

TEST_F(SimulatedMachineTest, TouchesThePlateAndItsChamfer) {
  machine.home();
  // Default plate: 200 × 150 × 10, top at M z = 0, corner 1 at M (200, 300) cut by a 5 mm chamfer.
  const Vec3 side_start(195, 375, -5);  // beside the x = 200 side, mid-thickness
  go(side_start);
  hal::TouchResult side = machine.probe(search(side_start, Vec3::UnitX()));
  ASSERT_TRUE(side.contact);
  EXPECT_NEAR(side.centre.x(), 199, 1e-9);
  // Along the diagonal into corner 1: the chamfer (x + y = 505 in M) meets the ball first.
  const Vec3 diagonal = Vec3(1, 1, 0).normalized();
  const Vec3 corner_start = Vec3(200, 300, -5) - 6 * diagonal;
  go(corner_start);
  hal::TouchResult chamfer = machine.probe(search(corner_start, diagonal));
  ASSERT_TRUE(chamfer.contact);
  EXPECT_NEAR((chamfer.centre.x() + chamfer.centre.y() - 505) / std::sqrt(2.0), -1, 1e-9);
}

TEST_F(SimulatedMachineTest, TouchesTheReferenceSphereAtItsRadius) {
  machine.home();
  const Vec3 c = machine.config().machine.reference_sphere.centre;  // radius 12.5
  go(c + Vec3(0, 0, 20));
  hal::TouchResult pole = machine.probe(search(c + Vec3(0, 0, 20), -Vec3::UnitZ()));
  ASSERT_TRUE(pole.contact);
  EXPECT_NEAR((pole.centre - c).norm(), 13.5, 1e-9);
}

TEST_F(SimulatedMachineTest, TheClockAdvancesByEachMotionsProfile) {
  machine.home();
  const double t0 = machine.status().t_s;
  machine.move({machine.status().position - Vec3(0, 0, 100), 0});  // 100 mm at 200 mm/s, 1000 mm/s²
  EXPECT_NEAR(machine.status().t_s - t0, 100.0 / 200 + 0.2, 1e-12);
}

TEST_F(SimulatedMachineTest, AStopAfterACommandWasAcceptedStopsItEvenBeforeItMoves) {
  machine.home();
  const Vec3 here = machine.status().position;
  machine.stop();  // idle and nothing accepted: nothing to stop, and nothing left standing
  machine.move({here - Vec3(0, 0, 10), 0});
  machine.accept_command();  // a front took a command off its link; the stop overtakes it
  machine.stop();
  EXPECT_THROW(machine.move({here - Vec3(0, 0, 20), 0}), hal::Aborted);
  EXPECT_LT((machine.status().position - (here - Vec3(0, 0, 10))).norm(), 1e-9);  // it never moved
  machine.move({here - Vec3(0, 0, 20), 0});  // the stop ended with its command
}

TEST_F(SimulatedMachineTest, AnIdleAbortLatchesUntilResetAndKeepsThePosition) {
  machine.home();
  machine.abort();  // as one that lands just after a motion ended
  EXPECT_TRUE(machine.status().aborted);
  EXPECT_THROW(machine.move({machine.status().position - Vec3(0, 0, 10), 0}), hal::Aborted);
  machine.reset();
  EXPECT_TRUE(machine.status().homed);  // nothing was moving, so nothing was lost
  machine.move({machine.status().position - Vec3(0, 0, 10), 0});
}

TEST(SimulatedMachineNoise, TriggerNoiseHasItsConfiguredSpread) {
  SimulatedMachine machine(sim_config_from_json({{"trigger_sigma_mm", 0.002}, {"seed", 11}, {"part", {{"analytic", "cube"}}}}));
  machine.home();
  // The cube (40 mm) stands at plate (50, 25): its top is M z = 40 around (270, 345).
  const Vec3 start(270, 345, 47);
  machine.move({Vec3(270, 345, 80), 0});
  double sum = 0, sum2 = 0;
  const int n = 400;
  for (int i = 0; i < n; ++i) {
    double dz = machine.probe(search(start, -Vec3::UnitZ())).centre.z() - 41;
    sum += dz, sum2 += dz * dz;
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_LT(std::abs(mean), 4 * 0.002 / std::sqrt(n));
  EXPECT_NEAR(sd, 0.002, 0.0003);  // about 4 standard errors of a 400-sample σ
}

}  // namespace
}  // namespace cmm::sim
