// Bore measurement against exact circles, noisy ones (Monte-Carlo against the predicted
// uncertainty), a slightly elliptic bore (roundness), and the refusals.
#include "planner/bore_measurement.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

namespace {

using cmm::planner::BoreInput;
using cmm::planner::BoreMeasurement;
using cmm::planner::CompensationError;
using cmm::planner::Vec3;

constexpr double two_pi = 2 * std::numbers::pi;

struct Frame {
  Vec3 origin, axis, u, v;
};

Frame random_frame(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> box(-300, 300);
  const Eigen::Matrix3d rotation =
      Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)).normalized().toRotationMatrix();
  return {Vec3(box(rng), box(rng), box(rng)), rotation.col(2), rotation.col(0), rotation.col(1)};
}

// Ball centres of a bore of radius `hole` touched at `angles`, `depth` below the frame's origin.
std::vector<Vec3> bore_centres(const Frame& f, double hole, double r, const std::vector<double>& angles, double depth) {
  std::vector<Vec3> centres;
  for (const double a : angles) {
    centres.push_back(f.origin - depth * f.axis + (hole - r) * (std::cos(a) * f.u + std::sin(a) * f.v));
  }
  return centres;
}

std::vector<double> even_angles(int n, double start = 0) {
  std::vector<double> angles;
  for (int i = 0; i < n; ++i) angles.push_back(start + two_pi * i / n);
  return angles;
}

TEST(Bore, ExactCirclesAreRecovered) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int k = 0; k < 200; ++k) {
    const Frame f = random_frame(rng);
    const double hole = 2 + 30 * unit(rng), r = 0.25 + std::min(1.5, hole / 3) * unit(rng);
    const int n = 3 + k % 6;
    std::vector<double> angles;
    // Anywhere on the circle, also on a short arc (the fit must not need a full turn).
    const double arc = k % 2 ? two_pi : 1.0;
    for (int i = 0; i < n; ++i) angles.push_back(arc * unit(rng));
    BoreInput in;
    in.hole_id = k;
    in.centres = bore_centres(f, hole, r, angles, 5);
    in.axis = k % 3 ? f.axis : Vec3(-f.axis);
    in.ball_radius_mm = r;
    const BoreMeasurement b = cmm::planner::measure_bore(in);
    ASSERT_LT((b.centre - (f.origin - 5 * f.axis)).norm(), 1e-9) << "hole " << hole << " n " << n;
    EXPECT_NEAR(b.diameter_mm, 2 * hole, 1e-9);
    EXPECT_LT(b.roundness_mm, 1e-9);
    EXPECT_LT(b.rms_mm, 1e-9);
    EXPECT_LT(b.depth_spread_mm, 1e-9);
    EXPECT_LT((b.axis - in.axis).norm(), 1e-15);
    EXPECT_EQ(b.residuals_mm.size(), static_cast<std::size_t>(n));
    const auto wall = cmm::planner::bore_wall_points(in, b);
    ASSERT_EQ(wall.size(), static_cast<std::size_t>(n));
    for (const auto& p : wall) {
      const Vec3 offset = p.position - b.centre;
      EXPECT_NEAR((offset - offset.dot(b.axis) * b.axis).norm(), hole, 1e-9);
    }
  }
}

TEST(Bore, CentreAtTheMeanDepthOfTouchesNotQuiteAtOne) {
  std::mt19937 rng(2);
  const Frame f = random_frame(rng);
  BoreInput in;
  in.hole_id = 1;
  in.centres = bore_centres(f, 6, 1, even_angles(6), 4);
  in.centres[0] -= 0.3 * f.axis;
  in.centres[3] += 0.1 * f.axis;
  in.axis = f.axis;
  in.ball_radius_mm = 1;
  const BoreMeasurement b = cmm::planner::measure_bore(in);
  EXPECT_LT((b.centre - (f.origin - (4 + 0.2 / 6) * f.axis)).norm(), 1e-9);
  EXPECT_NEAR(b.depth_spread_mm, 0.4, 1e-9);
  EXPECT_NEAR(b.diameter_mm, 12, 1e-9);
}

TEST(Bore, PredictedUncertaintyAgreesWithMonteCarlo) {
  std::mt19937 rng(3);
  const Frame f = random_frame(rng);
  const double sigma = 0.001, hole = 5, r = 1;
  BoreInput in;
  in.hole_id = 2;
  in.axis = f.axis;
  in.ball_radius_mm = r;
  in.trigger_sigma_mm = sigma;
  in.centres = bore_centres(f, hole, r, even_angles(6, 0.3), 2);
  const BoreMeasurement predicted = cmm::planner::measure_bore(in);
  // Six touches evenly spaced: centre σ·√(2/6) per axis, diameter 2σ/√6.
  EXPECT_NEAR(predicted.centre_sigma_mm, sigma * std::sqrt(2.0 / 6), 1e-12);
  EXPECT_NEAR(predicted.diameter_sigma_mm, 2 * sigma / std::sqrt(6.0), 1e-12);

  std::normal_distribution<double> noise(0, sigma);
  const int trials = 2000;
  double sum_d = 0, sum_d2 = 0;
  Eigen::Matrix3d centre_scatter = Eigen::Matrix3d::Zero();
  for (int k = 0; k < trials; ++k) {
    BoreInput noisy = in;
    for (Vec3& c : noisy.centres) c += Vec3(noise(rng), noise(rng), noise(rng));
    const BoreMeasurement b = cmm::planner::measure_bore(noisy);
    const Vec3 e = b.centre - predicted.centre;
    const Vec3 across = e - e.dot(f.axis) * f.axis;  // the mean depth moves too; the fit is across
    centre_scatter += across * across.transpose();
    sum_d += b.diameter_mm - predicted.diameter_mm;
    sum_d2 += std::pow(b.diameter_mm - predicted.diameter_mm, 2);
  }
  centre_scatter /= trials;
  const double mc_diameter = std::sqrt(sum_d2 / trials - std::pow(sum_d / trials, 2));
  for (const Vec3& dir : {f.u, f.v}) {
    EXPECT_NEAR(std::sqrt(dir.dot(centre_scatter * dir) / dir.dot(predicted.centre_covariance * dir)), 1, 0.2);
  }
  EXPECT_NEAR(mc_diameter / predicted.diameter_sigma_mm, 1, 0.2);
  std::printf("bore, 6 touches, 1 um noise: centre sigma predicted %.3f um MC %.3f um; diameter predicted %.3f um MC %.3f um\n",
              predicted.centre_sigma_mm * 1000, std::sqrt(f.u.dot(centre_scatter * f.u)) * 1000,
              predicted.diameter_sigma_mm * 1000, mc_diameter * 1000);
}

// Ball centre touching the inside of the ellipse (a cos t, b sin t) at parameter t: the wall point
// moved r along the inward normal (r below the smallest radius of curvature b²/a).
Eigen::Vector2d inner_offset(double a, double b, double r, double t) {
  const Eigen::Vector2d point(a * std::cos(t), b * std::sin(t));
  const Eigen::Vector2d outward = Eigen::Vector2d(b * std::cos(t), a * std::sin(t)).normalized();
  return point - r * outward;
}

TEST(Bore, SlightlyEllipticBoreRoundnessIsItsPeakToValley) {
  std::mt19937 rng(4);
  const Frame f = random_frame(rng);
  const double radius = 10, e = 0.01, a = radius + e, b = radius - e, r = 1.5;
  BoreInput in;
  in.hole_id = 3;
  in.axis = f.axis;
  in.ball_radius_mm = r;
  // Twelve touches including both axes' ends, where the radial distance is extreme.
  for (const double t : even_angles(12)) {
    const Eigen::Vector2d c = inner_offset(a, b, r, t);
    in.centres.push_back(f.origin + c.x() * f.u + c.y() * f.v);
  }
  const BoreMeasurement m = cmm::planner::measure_bore(in);
  // Peak-to-valley of the radial distance: (a − r) − (b − r) = a − b = 2e for semi-axes a, b.
  EXPECT_NEAR(m.roundness_mm, a - b, 1e-9);
  EXPECT_LT((m.centre - f.origin).norm(), 1e-9);
  EXPECT_NEAR(m.diameter_mm, a + b, 2e-3 * e);
  EXPECT_GT(m.rms_mm, 0.3 * e);
  EXPECT_LT(m.rms_mm, e);
}

TEST(Bore, RefusesTooFewCollinearAndNonFiniteTouches) {
  const auto reason = [](const BoreInput& in) {
    try {
      cmm::planner::measure_bore(in);
    } catch (const CompensationError& e) {
      EXPECT_EQ(e.id(), 5);
      EXPECT_NE(std::string(e.what()).find("hole 5:"), std::string::npos) << e.what();
      return e.reason();
    }
    ADD_FAILURE() << "accepted";
    return CompensationError::Reason::bad_input;
  };
  BoreInput in;
  in.hole_id = 5;
  in.axis = Vec3::UnitZ();
  in.ball_radius_mm = 1;
  in.centres = {Vec3(1, 0, 0), Vec3(0, 1, 0)};
  EXPECT_EQ(reason(in), CompensationError::Reason::bad_input);
  in.centres = {Vec3(1, 0, 0), Vec3(2, 0, 3), Vec3(3, 0, -1)};  // one line seen along the axis
  EXPECT_EQ(reason(in), CompensationError::Reason::degenerate);
  in.centres = {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(-1, NAN, 0)};
  EXPECT_EQ(reason(in), CompensationError::Reason::bad_input);
  in.centres = {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(-1, 0, 0)};
  in.axis = Vec3::Zero();
  EXPECT_EQ(reason(in), CompensationError::Reason::bad_input);
  in.axis = Vec3::UnitZ();
  EXPECT_NO_THROW(cmm::planner::measure_bore(in));
}

TEST(Bore, MapsToTheScanFrame) {
  Eigen::Isometry3d T_M_S = Eigen::Isometry3d::Identity();
  T_M_S.linear() = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  T_M_S.translation() = Vec3(5, 6, 7);
  BoreInput in;
  in.hole_id = 8;
  in.axis = Vec3::UnitZ();
  in.ball_radius_mm = 1;
  in.centres = {Vec3(3, 0, 0), Vec3(0, 3, 0), Vec3(-3, 0, 0), Vec3(0, -3, 0)};
  for (Vec3& c : in.centres) c = T_M_S * c;
  in.axis = T_M_S.linear() * in.axis;
  const BoreMeasurement s = cmm::planner::to_scan_frame(cmm::planner::measure_bore(in), T_M_S);
  EXPECT_EQ(s.frame, cmm::planner::PointFrame::scan);
  EXPECT_LT(s.centre.norm(), 1e-12);
  EXPECT_LT((s.axis - Vec3::UnitZ()).norm(), 1e-12);
  EXPECT_NEAR(s.diameter_mm, 8, 1e-12);
  EXPECT_NEAR(s.centre_covariance(2, 2), 0, 1e-20);
  EXPECT_THROW(cmm::planner::to_scan_frame(s, T_M_S), CompensationError);
}

}  // namespace
