// Base-plate registration: exact on exact corners, its predicted uncertainty matching 1,000 noisy
// trials, every kind of bad input refused with a message naming the corner, and corners.json in and
// the plan's "registration" out.
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "hal/description/json_fields.hpp"
#include "planner/registration.hpp"

namespace cmm::planner {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

Eigen::Isometry3d random_pose(std::mt19937_64& rng, double reach_mm = 500) {
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> u(-reach_mm, reach_mm);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
  pose.translation() = Vec3(u(rng), u(rng), u(rng));
  return pose;
}

// A pose that keeps the plate's top facing +z, as on a CMM table: a turn about z and a small tilt.
Eigen::Isometry3d table_pose(double turn_rad, const Vec3& translation) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = (Eigen::AngleAxisd(turn_rad, Vec3::UnitZ()) * Eigen::AngleAxisd(0.01, Vec3::UnitX())).toRotationMatrix();
  pose.translation() = translation;
  return pose;
}

json rectangle_json(double x = 200, double y = 150) {
  return {{"corners", {{0, 0, 0}, {x, 0, 0}, {x, y, 0}, {0, y, 0}}},
          {"thickness_mm", 10},
          {"fiducial", {{"kind", "chamfer"}, {"corner", 1}, {"size_mm", 5}}}};
}

// The plate in S (the scanner's view of it) and in M, exactly.
struct Scene {
  description::Plate plate;
  Eigen::Isometry3d T_S_P, T_M_S;
  Eigen::Isometry3d T_M_P() const { return T_M_S * T_S_P; }

  RegistrationInput input(std::vector<int> ids = {1, 2, 3, 4}) const {
    RegistrationInput in;
    for (int id : ids) {
      const Vec3 s = T_S_P * plate.corner(id);
      in.corners.push_back({id, s, T_M_S * s});
    }
    return in;
  }
  Vec3 fiducial_M() const { return T_M_P() * description::fiducial_geometry(plate).point; }
  Vec3 fiducial_S() const { return T_S_P * description::fiducial_geometry(plate).point; }
};

Scene scene(const json& plate = rectangle_json()) {
  Scene s;
  s.plate = description::plate_from_json(plate);
  // The plate 300-odd mm from the scanner's origin, so translation at the origin and at the centroid differ.
  s.T_S_P = Eigen::Isometry3d::Identity();
  s.T_S_P.linear() = Eigen::AngleAxisd(2.1, Vec3(0.3, 0.5, 1).normalized()).toRotationMatrix();
  s.T_S_P.translation() = Vec3(250, -120, 400);
  s.T_M_S = table_pose(0.4, Vec3(380, 220, -310)) * s.T_S_P.inverse();
  return s;
}

std::string error_of(const RegistrationInput& input, const description::Plate* plate = nullptr,
                     RegistrationError::Kind* kind = nullptr) {
  try {
    fit_registration(input, plate);
  } catch (const RegistrationError& e) {
    if (kind) *kind = e.kind();
    return e.what();
  }
  return "(no RegistrationError)";
}

// --- the fit -----------------------------------------------------------------------------------

TEST(RigidFit, NoiseFreePairsGiveTheTransformExactly) {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> u(-100, 100);
  for (int n : {3, 4, 8}) {
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::Isometry3d truth = random_pose(rng);
      std::vector<Vec3> from, to;
      for (int i = 0; i < n; ++i) {
        from.emplace_back(u(rng), u(rng), u(rng));
        to.push_back(truth * from.back());
      }
      const RigidFit fit = fit_rigid(from, to);
      EXPECT_NEAR((fit.transform.matrix() - truth.matrix()).cwiseAbs().maxCoeff(), 0, 1e-9) << "N = " << n;
      EXPECT_LT(fit.rms_mm, 1e-9);
      ASSERT_EQ(fit.residuals.size(), static_cast<std::size_t>(n));
    }
  }
}

TEST(RigidFit, NoiseFreePlateCornersThroughTheRegistration) {
  std::mt19937_64 rng(5);
  const description::Plate plate = description::plate_from_json(rectangle_json());
  for (int trial = 0; trial < 10; ++trial) {
    Scene s{plate, random_pose(rng), random_pose(rng)};
    for (const std::vector<int>& ids : {std::vector<int>{1, 2, 3}, std::vector<int>{1, 2, 3, 4}}) {
      const RegistrationResult r = fit_registration(s.input(ids));  // no plate: coplanar corners, any pose
      EXPECT_NEAR((r.T_M_S.matrix() - s.T_M_S.matrix()).cwiseAbs().maxCoeff(), 0, 1e-9);
    }
  }
}

TEST(RigidFit, AMirroredSetYieldsAProperRotationAndLargeResiduals) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-100, 100);
  const Eigen::Isometry3d truth = random_pose(rng);
  std::vector<Vec3> from, to;
  for (int i = 0; i < 8; ++i) {
    from.emplace_back(u(rng), u(rng), u(rng));
    to.push_back(truth * Vec3(-from.back().x(), from.back().y(), from.back().z()));
  }
  const RigidFit fit = fit_rigid(from, to);
  EXPECT_NEAR(fit.transform.linear().determinant(), 1, 1e-12);
  EXPECT_GT(fit.rms_mm, 10);
  // The registration refuses it: the lengths agree (a mirror keeps them), the residuals do not.
  RegistrationInput input;
  for (int i = 0; i < 8; ++i) input.corners.push_back({i + 1, from[static_cast<std::size_t>(i)], to[static_cast<std::size_t>(i)]});
  RegistrationError::Kind kind{};
  EXPECT_THAT(error_of(input, nullptr, &kind), HasSubstr("over the tolerance 0.050 mm"));
  EXPECT_EQ(kind, RegistrationError::Kind::rms);
}

TEST(RigidFit, PredictionAtTheCentroidAndTheOriginOfS) {
  const Scene s = scene();
  const RegistrationInput in = s.input();
  std::vector<Vec3> from;
  for (const auto& c : in.corners) from.push_back(c.scan);
  const RigidFitUncertainty u = predict_rigid_fit_uncertainty(from, s.T_M_S, 0.01, 0.01);
  EXPECT_NEAR(u.sigma_eff_mm, 0.01 * std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(u.translation_rms_at_centroid_mm, u.sigma_eff_mm * std::sqrt(3.0 / 4), 1e-15);
  EXPECT_NEAR(u.expected_rms_mm, u.sigma_eff_mm * std::sqrt(6.0 / 4), 1e-15);
  EXPECT_GT(u.translation_rms_at_origin_mm, u.translation_rms_at_centroid_mm);  // lever arm
  EXPECT_NEAR(u.rotation_rms_rad, std::sqrt(u.rotation_covariance.trace()), 1e-18);
  // The rectangle's in-plane rotation: Σ|p|² = 4 (100² + 75²); the prediction's axis there is the plate normal.
  const Vec3 normal_M = s.T_M_P().linear() * Vec3::UnitZ();
  EXPECT_NEAR(normal_M.dot(u.rotation_covariance * normal_M), 2e-4 / (4 * (100.0 * 100 + 75 * 75)), 1e-15);
  EXPECT_THROW(predict_rigid_fit_uncertainty(std::vector<Vec3>{Vec3::Zero(), Vec3::UnitX(), 2 * Vec3::UnitX()},
                                             Eigen::Isometry3d::Identity(), 0.01, 0.01),
               std::invalid_argument);
}

// --- Monte Carlo ---------------------------------------------------------------------------------

struct MonteCarlo {
  double rotation_rms_rad = 0, origin_rms_mm = 0, centroid_rms_mm = 0, residual_rms_mm = 0;
  double rotation_max_rad = 0, origin_max_mm = 0, centroid_max_mm = 0;
};

MonteCarlo run_trials(const Scene& s, double sigma_s, double sigma_m, int trials, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1);
  const RegistrationInput exact = s.input();
  Vec3 centroid_s = Vec3::Zero();
  for (const auto& c : exact.corners) centroid_s += c.scan;
  centroid_s /= static_cast<double>(exact.corners.size());
  MonteCarlo mc;
  std::vector<Vec3> scan(exact.corners.size()), machine(exact.corners.size());
  for (int t = 0; t < trials; ++t) {
    for (std::size_t i = 0; i < exact.corners.size(); ++i) {
      scan[i] = exact.corners[i].scan + sigma_s * Vec3(g(rng), g(rng), g(rng));
      machine[i] = exact.corners[i].machine + sigma_m * Vec3(g(rng), g(rng), g(rng));
    }
    // The fit alone: fit_registration's checks would only slow the 1,000 trials (one trial runs it below).
    const RigidFit fit = fit_rigid(scan, machine);
    const Eigen::Isometry3d& T = fit.transform;
    const Eigen::AngleAxisd w(T.linear() * s.T_M_S.linear().transpose());  // left error, M axes
    const double rotation = std::abs(w.angle());
    const double origin = (T.translation() - s.T_M_S.translation()).norm();
    const double centroid = (T * centroid_s - s.T_M_S * centroid_s).norm();
    mc.rotation_rms_rad += rotation * rotation;
    mc.origin_rms_mm += origin * origin;
    mc.centroid_rms_mm += centroid * centroid;
    mc.residual_rms_mm += fit.rms_mm * fit.rms_mm;
    if (t == 0) {
      RegistrationInput in = exact;
      for (std::size_t i = 0; i < exact.corners.size(); ++i) {
        in.corners[i].scan = scan[i];
        in.corners[i].machine = machine[i];
      }
      EXPECT_NEAR((fit_registration(in, &s.plate).T_M_S.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 0, 1e-12);
    }
    mc.rotation_max_rad = std::max(mc.rotation_max_rad, rotation);
    mc.origin_max_mm = std::max(mc.origin_max_mm, origin);
    mc.centroid_max_mm = std::max(mc.centroid_max_mm, centroid);
  }
  mc.rotation_rms_rad = std::sqrt(mc.rotation_rms_rad / trials);
  mc.origin_rms_mm = std::sqrt(mc.origin_rms_mm / trials);
  mc.centroid_rms_mm = std::sqrt(mc.centroid_rms_mm / trials);
  mc.residual_rms_mm = std::sqrt(mc.residual_rms_mm / trials);
  return mc;
}

// 1,000 seeded trials on the 200 × 150 mm plate's four corners. "Within 20 %": the empirical RMS of
// the per-trial error norm (|ω| of R_fit R_trueᵀ; |t_fit − t_true| at the origin of S; the error of
// the true S centroid's image) against the predicted RMS (sqrt of the covariance's trace). "No trial
// beyond 5 σ": every per-trial error norm below 5 × that predicted RMS.
void expect_prediction_holds(double sigma_s, double sigma_m, std::uint64_t seed) {
  const Scene s = scene();
  std::vector<Vec3> from;
  for (const auto& c : s.input().corners) from.push_back(c.scan);
  const RigidFitUncertainty p = predict_rigid_fit_uncertainty(from, s.T_M_S, sigma_s, sigma_m);
  const MonteCarlo mc = run_trials(s, sigma_s, sigma_m, 1000, seed);
  std::printf("σ_S %.3f σ_M %.3f mm: rotation RMS %.3e rad (predicted %.3e), translation RMS at S origin %.4f mm "
              "(predicted %.4f), at centroid %.4f mm (predicted %.4f), residual RMS %.4f mm (predicted %.4f); "
              "max/predicted RMS: rotation %.2f, origin %.2f, centroid %.2f\n",
              sigma_s, sigma_m, mc.rotation_rms_rad, p.rotation_rms_rad, mc.origin_rms_mm,
              p.translation_rms_at_origin_mm, mc.centroid_rms_mm, p.translation_rms_at_centroid_mm,
              mc.residual_rms_mm, p.expected_rms_mm, mc.rotation_max_rad / p.rotation_rms_rad,
              mc.origin_max_mm / p.translation_rms_at_origin_mm, mc.centroid_max_mm / p.translation_rms_at_centroid_mm);
  EXPECT_NEAR(mc.rotation_rms_rad / p.rotation_rms_rad, 1, 0.2);
  EXPECT_NEAR(mc.origin_rms_mm / p.translation_rms_at_origin_mm, 1, 0.2);
  EXPECT_NEAR(mc.centroid_rms_mm / p.translation_rms_at_centroid_mm, 1, 0.2);
  EXPECT_NEAR(mc.residual_rms_mm / p.expected_rms_mm, 1, 0.2);
  EXPECT_LT(mc.rotation_max_rad, 5 * p.rotation_rms_rad);
  EXPECT_LT(mc.origin_max_mm, 5 * p.translation_rms_at_origin_mm);
  EXPECT_LT(mc.centroid_max_mm, 5 * p.translation_rms_at_centroid_mm);
}

TEST(RegistrationMonteCarlo, NoiseOnBothSidesMatchesThePrediction) { expect_prediction_holds(0.01, 0.01, 1); }
TEST(RegistrationMonteCarlo, NoiseOnTheMachineSideOnlyMatchesThePrediction) { expect_prediction_holds(0, 0.01, 2); }
TEST(RegistrationMonteCarlo, UnequalNoiseMatchesThePrediction) { expect_prediction_holds(0.02, 0.005, 3); }

// --- bad input, named ------------------------------------------------------------------------------

TEST(RegistrationRefuses, FewerThanThreeCorners) {
  const Scene s = scene();
  RegistrationError::Kind kind{};
  EXPECT_THAT(error_of(s.input({1, 2}), &s.plate, &kind), HasSubstr("at least three corners measured in both S and M, got 2"));
  EXPECT_EQ(kind, RegistrationError::Kind::too_few_corners);
}

TEST(RegistrationRefuses, DuplicateAndUnknownCornerIds) {
  const Scene s = scene();
  EXPECT_THAT(error_of(s.input({1, 2, 2, 3}), &s.plate), HasSubstr("corner 2 is listed twice"));
  RegistrationInput in = s.input();
  in.corners[3].id = 7;
  EXPECT_THAT(error_of(in, &s.plate), HasSubstr("corner 7 is not a corner of the plate (ids 1–4)"));
}

TEST(RegistrationRefuses, NonFiniteCoordinatesNamingCornerAndFrame) {
  const Scene s = scene();
  RegistrationInput in = s.input();
  in.corners[2].machine.y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(error_of(in, &s.plate), HasSubstr("corner 3: machine (M) y is NaN"));
  in = s.input();
  in.corners[1].scan.x() = -std::numeric_limits<double>::infinity();
  RegistrationError::Kind kind{};
  EXPECT_THAT(error_of(in, &s.plate, &kind), HasSubstr("corner 2: scan (S) x is infinite"));
  EXPECT_EQ(kind, RegistrationError::Kind::not_finite);
}

TEST(RegistrationRefuses, CoincidentCorners) {
  const Scene s = scene();
  RegistrationInput in = s.input();
  in.corners[3].machine = in.corners[0].machine + Vec3(0.01, 0, 0);
  RegistrationError::Kind kind{};
  const std::string message = error_of(in, &s.plate, &kind);
  EXPECT_THAT(message, HasSubstr("corners 1 and 4 coincide in M (0.010 mm apart"));
  EXPECT_EQ(kind, RegistrationError::Kind::coincident);
}

TEST(RegistrationRefuses, CollinearCorners) {
  RegistrationInput in;
  const std::vector<Vec3> s{{0, 0, 0}, {100, 0.05, 0}, {200, 0, 0}, {300, 0.02, 0.01}};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Vec3(10, 20, 30);
  for (int i = 0; i < 4; ++i) in.corners.push_back({i + 1, s[static_cast<std::size_t>(i)], T * s[static_cast<std::size_t>(i)]});
  RegistrationError::Kind kind{};
  const std::string message = error_of(in, nullptr, &kind);
  EXPECT_THAT(message, HasSubstr("corners 1, 2, 3, 4 are collinear in S"));
  EXPECT_THAT(message, HasSubstr("rotation about that line is undetermined"));
  EXPECT_EQ(kind, RegistrationError::Kind::collinear);
}

TEST(RegistrationRefuses, ASideThatDisagreesWithThePlate) {
  const Scene s = scene();
  RegistrationInput in = s.input();
  // Corner 3 measured 1.29 mm toward corner 2: side 2–3 becomes 148.71 mm, diagonal 1–3 249.23 mm.
  in.corners[2].machine = s.T_M_P() * Vec3(200, 148.71, 0);
  RegistrationError::Kind kind{};
  const std::string message = error_of(in, &s.plate, &kind);
  EXPECT_THAT(message, HasSubstr("side corner 2–corner 3 is 148.71 mm in M, the plate says 150.00 mm"));
  EXPECT_THAT(message, HasSubstr("diagonal corner 1–corner 3 is 249.23 mm in M, the plate says 250.00 mm"));
  EXPECT_THAT(message, HasSubstr("corner 3 is in every one"));
  EXPECT_EQ(kind, RegistrationError::Kind::nominal_length);
}

TEST(RegistrationRefuses, LengthsThatDifferBetweenSAndM) {
  // Without a plate: a scan 1 % too large.
  const Scene s = scene();
  RegistrationInput in = s.input();
  for (auto& c : in.corners) c.scan *= 1.01;
  RegistrationError::Kind kind{};
  EXPECT_THAT(error_of(in, nullptr, &kind), HasSubstr("distance corner 1–corner 2 is 202.00 mm in S but 200.00 mm in M"));
  EXPECT_EQ(kind, RegistrationError::Kind::frame_length);
  // With the plate: each frame within its 0.5 mm of the plate, but 0.6 mm apart on side 2–3.
  in = s.input();
  in.corners[2].scan = s.T_S_P * Vec3(200, 150.3, 0);
  in.corners[2].machine = s.T_M_P() * Vec3(200, 149.7, 0);
  EXPECT_THAT(error_of(in, &s.plate, &kind), HasSubstr("side corner 2–corner 3 is 150.30 mm in S but 149.70 mm in M"));
  EXPECT_EQ(kind, RegistrationError::Kind::frame_length);
}

TEST(RegistrationRefuses, RmsOverTheTolerance) {
  const Scene s = scene();
  RegistrationInput in = s.input();
  std::mt19937_64 rng(17);
  std::normal_distribution<double> g(0, 0.1);
  for (auto& c : in.corners) c.machine += Vec3(g(rng), g(rng), g(rng));
  RegistrationError::Kind kind{};
  const std::string message = error_of(in, &s.plate, &kind);
  EXPECT_THAT(message, HasSubstr("mm is over the tolerance 0.050 mm"));
  EXPECT_THAT(message, HasSubstr("the largest residual is corner"));
  EXPECT_EQ(kind, RegistrationError::Kind::rms);
  in.options.rms_tolerance_mm = 1;
  EXPECT_NO_THROW(fit_registration(in, &s.plate));
}

TEST(RegistrationRefuses, AMirroredOrderInM) {
  // A square plate: a mirrored order keeps every length, so only the handedness can tell.
  const Scene s = scene(rectangle_json(150, 150));
  RegistrationInput in = s.input();
  std::swap(in.corners[1].machine, in.corners[3].machine);  // 1, 4, 3, 2: clockwise seen from above
  RegistrationError::Kind kind{};
  const std::string message = error_of(in, &s.plate, &kind);
  EXPECT_THAT(message, HasSubstr("go clockwise seen from above (+z) in M"));
  EXPECT_THAT(message, HasSubstr("the corner order is mirrored"));
  EXPECT_EQ(kind, RegistrationError::Kind::mirrored);
}

// --- one frame's corners alone, before anything moves (issue 34) ---------------------------------

std::string plate_corner_error(const std::vector<int>& ids, const std::vector<Vec3>& points, char frame,
                               const description::Plate& plate, double tolerance, std::vector<int>* corners = nullptr,
                               RegistrationError::Kind* kind = nullptr) {
  try {
    check_plate_corners(ids, points, frame, frame == 'S' ? "scan_corners (S)" : "rough_machine (M)", plate, tolerance);
  } catch (const RegistrationError& e) {
    if (corners) *corners = e.corners();
    if (kind) *kind = e.kind();
    return e.what();
  }
  return "";
}

TEST(PlateCornersAlone, SwappedScanCornersAreRefusedByTheirLengths) {
  const Scene s = scene();
  std::vector<Vec3> scan;
  for (int id = 1; id <= 4; ++id) scan.push_back(s.T_S_P * s.plate.corner(id));
  EXPECT_EQ(plate_corner_error({1, 2, 3, 4}, scan, 'S', s.plate, 0.5), "");
  std::swap(scan[1], scan[2]);  // corners 2 and 3 given in each other's place
  RegistrationError::Kind kind{};
  const std::string message = plate_corner_error({1, 2, 3, 4}, scan, 'S', s.plate, 0.5, nullptr, &kind);
  EXPECT_THAT(message, HasSubstr("scan_corners (S): "));
  EXPECT_THAT(message, HasSubstr("in S, the plate says"));
  EXPECT_THAT(message, HasSubstr("the one given as corner 2 is corner 3, the one given as corner 3 is corner 2): corners swapped?"));
  EXPECT_EQ(kind, RegistrationError::Kind::nominal_length);
}

TEST(PlateCornersAlone, ARoughCornerFarOffIsBlamedOnThatCorner) {
  const Scene s = scene();
  std::vector<Vec3> rough;
  for (int id = 1; id <= 4; ++id) rough.push_back(s.T_M_P() * s.plate.corner(id) + Vec3(0.8, -0.6, 0.2));
  EXPECT_EQ(plate_corner_error({1, 2, 3, 4}, rough, 'M', s.plate, 4), "");
  rough[1] += s.T_M_P().linear() * Vec3(30, 0, 0);  // corner 2 taught 30 mm off along its side
  std::vector<int> corners;
  const std::string message = plate_corner_error({1, 2, 3, 4}, rough, 'M', s.plate, 4, &corners);
  EXPECT_THAT(message, HasSubstr("rough_machine (M): "));
  EXPECT_THAT(message, HasSubstr("corner 2 is in every one: it is probably the one that is off"));
  EXPECT_EQ(corners, std::vector<int>{2});
}

TEST(PlateCornersAlone, AMirroredOrderInMIsRefusedAndInSOnlyWithItsUp) {
  const Scene s = scene(rectangle_json(150, 150));
  std::vector<Vec3> machine, scan;
  for (int id : {1, 4, 3, 2}) {
    machine.push_back(s.T_M_P() * s.plate.corner(id));
    scan.push_back(s.T_S_P * s.plate.corner(id));
  }
  RegistrationError::Kind kind{};
  EXPECT_THAT(plate_corner_error({1, 2, 3, 4}, machine, 'M', s.plate, 0.5, nullptr, &kind),
              HasSubstr("the corner order is mirrored"));
  EXPECT_EQ(kind, RegistrationError::Kind::mirrored);
  EXPECT_EQ(plate_corner_error({1, 2, 3, 4}, scan, 'S', s.plate, 0.5), "");  // S's up is not known
  EXPECT_THROW(check_plate_corners({1, 2, 3, 4}, scan, 'S', "scan", s.plate, 0.5, s.T_S_P.linear() * Vec3::UnitZ()),
               RegistrationError);
}

TEST(PlateCornersAlone, UnknownOrRepeatedIdsAndTooFewCorners) {
  const Scene s = scene();
  const std::vector<Vec3> three = {s.T_S_P * s.plate.corner(1), s.T_S_P * s.plate.corner(2), s.T_S_P * s.plate.corner(3)};
  EXPECT_THAT(plate_corner_error({1, 2, 7}, three, 'S', s.plate, 0.5), HasSubstr("corner 7 is listed twice or is not a corner"));
  EXPECT_THAT(plate_corner_error({1, 2}, {three[0], three[1]}, 'S', s.plate, 0.5), HasSubstr("at least three corners"));
}

TEST(RegistrationRefuses, AMirroredOrderInSWhenTheScanKnowsItsUp) {
  const Scene s = scene(rectangle_json(150, 150));
  RegistrationInput in = s.input();
  std::swap(in.corners[1].scan, in.corners[3].scan);  // 1, 4, 3, 2 in S
  // A mirrored planar set is a rotated one (turned over): without an up direction in S nothing in
  // the corners tells, and the fit would put the scan upside down in M.
  const RegistrationResult unchecked = fit_registration(in, &s.plate);
  EXPECT_LT((unchecked.T_M_S.linear() * s.T_S_P.linear() * Vec3::UnitZ()).z(), 0);
  EXPECT_THAT(unchecked.notes, ::testing::Contains(HasSubstr("no fiducial and no scan_up in S")));

  in.scan_up = s.T_S_P.linear() * Vec3::UnitZ();  // the scan's outward normal of the plate's top
  RegistrationError::Kind kind{};
  const std::string message = error_of(in, &s.plate, &kind);
  EXPECT_THAT(message, HasSubstr("go clockwise seen from scan_up in S"));
  EXPECT_THAT(message, HasSubstr("is mirrored"));
  EXPECT_EQ(kind, RegistrationError::Kind::mirrored);
  // Without a plate, scan_up still catches it: T_M_S turns it downward.
  EXPECT_THAT(error_of(in), HasSubstr("turns the scan's up direction (scan_up) downward in M"));
  // And a fiducial measured in S catches it through the plate's thickness: the turned-over pose puts
  // the chamfer's mid-thickness above the top.
  in.scan_up.reset();
  in.fiducial_scan = s.fiducial_S();
  EXPECT_THAT(error_of(in, &s.plate), HasSubstr("fiducial in S: the chamfer at corner 1 is not where corner 1 should be"));
}

TEST(RegistrationRefuses, CornersShiftedByTwoPositions) {
  // The machine corners labelled from the opposite corner: every length agrees, the fit is perfect,
  // but the chamfer measured in M is at the corner labelled 3.
  const Scene s = scene();
  RegistrationInput in = s.input();
  for (auto& c : in.corners) c.machine = s.T_M_P() * s.plate.corner((c.id + 1) % 4 + 1);
  in.fiducial_machine = s.fiducial_M();
  RegistrationError::Kind kind{};
  const std::string message = error_of(in, &s.plate, &kind);
  EXPECT_THAT(message, HasSubstr("the chamfer at corner 1 is not where corner 1 should be"));
  EXPECT_THAT(message, HasSubstr("the corner order looks shifted by 2"));
  EXPECT_THAT(message, HasSubstr("the corner labelled 3 is the plate's corner 1"));
  EXPECT_EQ(kind, RegistrationError::Kind::fiducial);
}

TEST(RegistrationRefuses, CornersShiftedByTwoWithAHoleFiducial) {
  json plate = rectangle_json();
  plate["fiducial"] = {{"kind", "hole"}, {"centre", {20, 15}}, {"diameter_mm", 6}};
  const Scene s = scene(plate);
  RegistrationInput in = s.input();
  for (auto& c : in.corners) c.scan = s.T_S_P * s.plate.corner((c.id + 1) % 4 + 1);  // shifted in S this time
  in.fiducial_machine = s.fiducial_M();
  in.fiducial_scan = s.fiducial_S();
  const std::string message = error_of(in, &s.plate);
  EXPECT_THAT(message, HasSubstr("fiducial in S: the hole near corner 1 is not where corner 1 should be"));
  EXPECT_THAT(message, HasSubstr("shifted by 2"));
}

TEST(RegistrationRefuses, AFiducialNoRelabellingExplains) {
  const Scene s = scene();
  RegistrationInput in = s.input();
  const description::FiducialGeometry g = description::fiducial_geometry(s.plate);
  in.fiducial_machine = s.T_M_P() * (g.point - 2 * g.normal);  // 2 mm inside the chamfer
  EXPECT_THAT(error_of(in, &s.plate), HasSubstr("2.00 mm off the chamfer face's plane"));
  EXPECT_THAT(error_of(in, &s.plate), HasSubstr("no cyclic relabelling of the corners explains it"));
}

// --- a good fit, and what it says ---------------------------------------------------------------

TEST(Registration, AVerifiedFitReportsItsChecks) {
  const Scene s = scene();
  RegistrationInput in = s.input();
  const description::FiducialGeometry g = description::fiducial_geometry(s.plate);
  in.fiducial_machine = s.T_M_P() * (g.point + 1.5 * g.along + Vec3(0, 0, 3));  // anywhere on the face
  in.fiducial_scan = s.fiducial_S();
  const RegistrationResult r = fit_registration(in, &s.plate);
  EXPECT_TRUE(r.order_verified);
  ASSERT_EQ(r.fiducial_checks.size(), 2u);
  EXPECT_LT(r.fiducial_checks[0].deviation.off_mm, 1e-9);
  EXPECT_EQ(r.fiducial_checks[0].deviation.outside_mm, 0);
  ASSERT_TRUE(r.T_M_P.has_value());
  EXPECT_NEAR((r.T_M_P->matrix() - s.T_M_P().matrix()).cwiseAbs().maxCoeff(), 0, 1e-9);
  EXPECT_NEAR((r.T_M_S.matrix() - s.T_M_S.matrix()).cwiseAbs().maxCoeff(), 0, 1e-9);

  const json j = to_json(r);
  ASSERT_EQ(j["T_M_S"].size(), 4u);
  for (int row = 0; row < 4; ++row) {
    ASSERT_EQ(j["T_M_S"][static_cast<std::size_t>(row)].size(), 4u);
    for (int col = 0; col < 4; ++col)
      EXPECT_NEAR(j["T_M_S"][static_cast<std::size_t>(row)][static_cast<std::size_t>(col)].get<double>(),
                  s.T_M_S.matrix()(row, col), 1e-9);
  }
  EXPECT_EQ(j["T_M_S"][3], json::array({0.0, 0.0, 0.0, 1.0}));
  ASSERT_EQ(j["residuals_mm"].size(), 4u);
  EXPECT_GE(j["residuals_mm"][0].get<double>(), 0);
  EXPECT_LT(j["rms_mm"].get<double>(), 1e-9);
  for (const char* key : {"rotation_rms_rad", "rotation_rms_deg", "translation_rms_at_centroid_mm",
                          "translation_rms_at_origin_mm", "expected_rms_mm", "sigma_eff_mm", "covariance"})
    EXPECT_TRUE(j["predicted"].contains(key)) << key;
  EXPECT_EQ(j["predicted"]["covariance"].size(), 6u);
  EXPECT_TRUE(j["order_verified"].get<bool>());
  EXPECT_EQ(j["fiducial"].size(), 2u);
}

TEST(Registration, WithoutAFiducialTheOrderIsNotVerifiedAndSaysSo) {
  const Scene s = scene();
  const RegistrationResult r = fit_registration(s.input(), &s.plate);
  EXPECT_FALSE(r.order_verified);
  EXPECT_THAT(r.notes, ::testing::Contains(HasSubstr("not verified: no fiducial measured in M")));
  const RegistrationResult bare = fit_registration(s.input());
  EXPECT_THAT(bare.notes, ::testing::Contains(HasSubstr("no plate description")));
}

// --- corners.json ---------------------------------------------------------------------------------

class CornersFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("cmmd_registration_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" + std::to_string(getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    std::filesystem::copy_file(std::filesystem::path(CMMD_SOURCE_DIR) / "config" / "plate.json", dir_ / "plate.json");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  json corners_json() const {
    const Scene s = scene();
    json corners = json::array();
    for (const auto& c : s.input().corners)
      corners.push_back({{"id", c.id},
                         {"scan", {c.scan.x(), c.scan.y(), c.scan.z()}},
                         {"machine", {c.machine.x(), c.machine.y(), c.machine.z()}}});
    const Vec3 f = s.fiducial_M();
    return {{"plate", "plate.json"},
            {"noise_mm", 0.01},
            {"corners", corners},
            {"fiducial", {{"machine", {f.x(), f.y(), f.z()}}}},
            {"rms_tolerance_mm", 0.05}};
  }

  std::filesystem::path write(const json& j, const std::string& name = "corners.json") const {
    std::ofstream(dir_ / name) << j.dump(2);
    return dir_ / name;
  }

  std::string error_reading(const json& j) const {
    try {
      read_registration(write(j));
    } catch (const cmm::description::FieldError& e) {
      return e.what();
    }
    return "(no FieldError)";
  }

  std::filesystem::path dir_;
};

TEST_F(CornersFile, ReadsFitsAndWritesThePlanRegistration) {
  const RegistrationInput in = read_registration(write(corners_json()));
  ASSERT_TRUE(in.plate.has_value());
  EXPECT_EQ(in.plate->fiducial.size_mm, 5);
  EXPECT_EQ(in.corners.size(), 4u);
  EXPECT_EQ(in.noise_scan_mm, 0.01);
  EXPECT_EQ(in.noise_machine_mm, 0.01);
  EXPECT_TRUE(in.fiducial_machine.has_value());
  EXPECT_TRUE(in.notes.empty());
  const RegistrationResult r = fit_registration(in);
  EXPECT_TRUE(r.order_verified);
  EXPECT_NEAR((r.T_M_S.matrix() - scene().T_M_S.matrix()).cwiseAbs().maxCoeff(), 0, 1e-9);
  const json plan_registration = to_json(r);
  EXPECT_EQ(plan_registration["residuals_mm"].size(), 4u);
}

TEST_F(CornersFile, InlinePlateSeparateNoiseAndDefaults) {
  json j = corners_json();
  j["plate"] = rectangle_json();
  j.erase("noise_mm");
  j["noise_scan_mm"] = 0.05;
  RegistrationInput in = read_registration(write(j));
  EXPECT_EQ(in.noise_scan_mm, 0.05);
  EXPECT_EQ(in.noise_machine_mm, 0.01);
  EXPECT_THAT(in.notes, ::testing::Contains(HasSubstr("noise_mm not given")));
  j.erase("noise_scan_mm");
  j.erase("plate");
  in = read_registration(write(j));
  EXPECT_FALSE(in.plate.has_value());
  const RegistrationResult r = fit_registration(in);
  EXPECT_FALSE(r.order_verified);
}

TEST_F(CornersFile, ErrorsNameTheFileAndTheField) {
  json j = corners_json();
  j["corners"][1]["machine"] = {1, 2};
  std::string message = error_reading(j);
  EXPECT_THAT(message, HasSubstr("corners.json: /corners/1/machine: must be [x, y, z], not [1,2]"));

  j = corners_json();
  j["corners"][2]["scan"][1] = "12";
  EXPECT_THAT(error_reading(j), HasSubstr("corners.json: /corners/2/scan/1: must be a finite number"));

  j = corners_json();
  j["corners"][0].erase("id");
  EXPECT_THAT(error_reading(j), HasSubstr("/corners/0/id: missing (an integer corner id)"));

  j = corners_json();
  j.erase("corners");
  EXPECT_THAT(error_reading(j), HasSubstr("corners.json: /corners: missing"));

  j = corners_json();
  j["rms_tolerance"] = 0.1;
  EXPECT_THAT(error_reading(j), HasSubstr("corners.json: /rms_tolerance: unknown key"));

  j = corners_json();
  j["noise_mm"] = 0;
  EXPECT_THAT(error_reading(j), HasSubstr("/noise_mm: must be positive"));

  j = corners_json();
  j["fiducial"] = {{"machin", {1, 2, 3}}};
  EXPECT_THAT(error_reading(j), HasSubstr("/fiducial/machin: unknown key"));

  j = corners_json();
  j["plate"] = "no_such_plate.json";
  EXPECT_THAT(error_reading(j), HasSubstr("no_such_plate.json: cannot open"));

  j = corners_json();
  j["plate"]= rectangle_json();
  j["plate"]["thickness_mm"] = "ten";
  EXPECT_THAT(error_reading(j), HasSubstr("corners.json: /plate/thickness_mm: must be a number"));

  std::ofstream(dir_ / "torn.json") << "{\"corners\": [{\"id\": 1,";
  try {
    read_registration(dir_ / "torn.json");
    ADD_FAILURE() << "no error";
  } catch (const cmm::description::FieldError& e) {
    EXPECT_THAT(e.what(), HasSubstr("torn.json: not valid JSON at byte"));
  }
}

}  // namespace
}  // namespace cmm::planner
