// Sweeps a plan's touches against the true part; see true_part_touches.hpp.
#include "true_part_touches.hpp"

#include <numbers>
#include <random>

#include "geometry/ball_sweep.hpp"

namespace cmm::planner::testing {

TrueTouches touch_true_part(const geometry::TriangleMesh& true_part, const Eigen::Isometry3d& T_M_S,
                            const MeasurementPlan& plan, double radius_mm, double sigma_mm, std::uint64_t seed) {
  geometry::TriangleMesh in_m = true_part;
  for (Eigen::Index i = 0; i < in_m.vertices.rows(); ++i)
    in_m.vertices.row(i) = (T_M_S * Vec3(true_part.vertices.row(i).transpose())).transpose();
  const geometry::BallSweeper part(in_m);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, sigma_mm);
  TrueTouches out;
  const auto touch = [&](const Touch& t) {
    ++out.swept;
    const auto hit = part.first_hit(t.start, t.direction, t.max_travel_mm, radius_mm);
    out.missed += !hit;
    out.outcomes[t.id] = hit ? TouchOutcome{true, hit->centre + Vec3(noise(rng), noise(rng), noise(rng))}
                             : TouchOutcome{false, t.start + t.max_travel_mm * t.direction};
  };
  for (const EdgePlan& e : plan.edges)
    for (const Touch& t : e.touches) touch(t);
  for (const BorePlan& b : plan.bores)
    for (const Touch& t : b.touches) touch(t);
  return out;
}

Eigen::Isometry3d tilted_machine_pose() {
  constexpr double deg = std::numbers::pi / 180;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translate(Vec3(250, 300, -20));
  T.rotate(Eigen::AngleAxisd(30 * deg, Vec3::UnitZ()));
  T.rotate(Eigen::AngleAxisd(0.5 * deg, Vec3::UnitX()));
  return T;
}

}  // namespace cmm::planner::testing
