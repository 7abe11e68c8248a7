// Compensation of edge touches against exact wedges and planes: exact recovery, the worst case of
// DESIGN.md's 2-D model under trigger noise, predicted uncertainty against Monte-Carlo, refusals.
#include "planner/edge_compensation.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

namespace {

using cmm::planner::CompensationError;
using cmm::planner::EdgeDeviation;
using cmm::planner::FaceEdgeInput;
using cmm::planner::MeasuredPoint;
using cmm::planner::PointFrame;
using cmm::planner::TwoTouchInput;
using cmm::planner::Vec3;

constexpr double deg = std::numbers::pi / 180;

Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
  return q.normalized().toRotationMatrix();
}

// A straight convex edge: apex Q, tangent t, the material-side bisector `axis` (into the material),
// placed anywhere in space by a rotation. Its cross-section frame: e1 = axis, e2 = t × e1.
struct Wedge {
  Vec3 apex, tangent, axis, e2;
  double alpha = 0;  // interior (material) angle

  Vec3 in_plane(double along_axis, double across) const { return along_axis * axis + across * e2; }
  // Outward normals of the two faces: the bisector −axis turned by ±(π − α)/2 in the plane.
  Vec3 normal(int side) const {
    const double half = (std::numbers::pi - alpha) / 2;
    return in_plane(-std::cos(half), side == 0 ? std::sin(half) : -std::sin(half));
  }
};

Wedge random_wedge(std::mt19937& rng, double alpha) {
  std::uniform_real_distribution<double> box(-200, 200);
  const Eigen::Matrix3d rotation = random_rotation(rng);
  Wedge w;
  w.apex = Vec3(box(rng), box(rng), box(rng));
  w.tangent = rotation.col(2);
  w.axis = rotation.col(0);
  w.e2 = w.tangent.cross(w.axis);
  w.alpha = alpha;
  return w;
}

// The centre where a ball of radius r moving along the line (a, d) first touches the apex q: the
// smaller root of |a + s d − q| = r.
Vec3 first_touch(const Vec3& a, const Vec3& d, const Vec3& q, double r) {
  const Vec3 w = a - q;
  const double b = w.dot(d);
  const double discriminant = b * b - w.squaredNorm() + r * r;
  EXPECT_GE(discriminant, 0);
  return a + (-b - std::sqrt(std::max(0.0, discriminant))) * d;
}

// φ = acos(δ/r) − α/2 (DESIGN.md, probe_window.hpp).
double half_angle(double alpha, double r, double delta) { return std::acos(delta / r) - alpha / 2; }

struct Case {
  Wedge wedge;
  TwoTouchInput input;
};

// Reference point A within δ of the apex in the cross-section plane, approaches at axis ± β through
// A, exact first-touch centres, each then slid along the edge (a straight edge does not care).
Case make_case(std::mt19937& rng, double alpha, double r, double delta, double beta) {
  std::uniform_real_distribution<double> unit(0, 1), slide(-3, 3);
  Case c;
  c.wedge = random_wedge(rng, alpha);
  const Wedge& w = c.wedge;
  const double offset = delta * std::sqrt(unit(rng)), angle = 2 * std::numbers::pi * unit(rng);
  const Vec3 a = w.apex + w.in_plane(offset * std::cos(angle), offset * std::sin(angle));
  c.input.id = 7;
  c.input.reference_point = a;
  c.input.tangent = w.tangent;
  c.input.window_axis = w.axis;
  c.input.ball_radius_mm = r;
  for (int i = 0; i < 2; ++i) {
    const double b = i == 0 ? beta : -beta;
    c.input.approach[i] = w.in_plane(std::cos(b), std::sin(b));
    c.input.centre[i] = first_touch(a, c.input.approach[i], w.apex, r) + slide(rng) * w.tangent;
  }
  return c;
}

TEST(TwoTouchEdge, RecoversTheApexExactlyForAnyWedgeRadiusAndWindow) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0, 1);
  int ambiguous = 0;  // cases where both intersections lie ahead of both balls and the axis decides
  for (int k = 0; k < 2000; ++k) {
    const double alpha = (30 + 140 * unit(rng)) * deg;
    const double r = 0.5 + 4.5 * unit(rng);
    const double delta = 0.95 * unit(rng) * r * std::cos(alpha / 2);  // leaves φ > 0
    const double phi = half_angle(alpha, r, delta);
    ASSERT_GT(phi, 0);
    const double beta = (0.05 + 0.95 * unit(rng)) * phi;
    if (beta > 45 * deg) ++ambiguous;
    const Case c = make_case(rng, alpha, r, delta, beta);
    const MeasuredPoint x = cmm::planner::measure_edge_two_touch(c.input);
    ASSERT_LT((x.position - c.wedge.apex).norm(), 1e-9)
        << "alpha " << alpha / deg << "° r " << r << " delta " << delta << " beta " << beta / deg << "°";
    EXPECT_FALSE(x.clamped);
    EXPECT_NEAR(x.sensitivity, 1 / std::sin(beta), 1e-6 * x.sensitivity);
    EXPECT_NEAR(std::abs(x.tangent.dot(c.wedge.tangent)), 1, 1e-12);
    EXPECT_LE(x.out_of_plane_mm, 3 + 1e-9);
    EXPECT_EQ(x.frame, PointFrame::machine);
  }
  EXPECT_GT(ambiguous, 40);  // the axis tie-break was exercised
}

// Worst error over 20,000 cases of the 2-D model with 1 µm trigger noise (isotropic Gaussian on
// each centre) and β = 0.9 φ: α uniform in 30–170°, r in 0.5–5 mm, δ in 0–0.5 mm and at most r/2
// (as δ/r nears 1 the contact normals turn toward each other and the error outgrows 1/sin β), the
// reference point uniform in the δ-disc. With `fixed_phi` ≤ 0 the cases are those whose φ ≥ 20°;
// otherwise α is solved from φ = fixed_phi (up to 178°).
double worst_error_um(std::mt19937& rng, double fixed_phi) {
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> noise(0, 0.001);
  double worst = 0;
  for (int k = 0; k < 20000;) {
    const double r = 0.5 + 4.5 * unit(rng);
    const double delta = 0.5 * unit(rng);
    if (delta > r / 2) continue;
    double alpha = (30 + 140 * unit(rng)) * deg;
    if (fixed_phi > 0) alpha = 2 * (std::acos(delta / r) - fixed_phi);
    if (alpha < 30 * deg || alpha > (fixed_phi > 0 ? 178 : 170) * deg) continue;
    const double phi = half_angle(alpha, r, delta);
    if (fixed_phi <= 0 && phi < 20 * deg) continue;
    ++k;
    Case c = make_case(rng, alpha, r, delta, 0.9 * phi);
    for (Vec3& centre : c.input.centre) centre += Vec3(noise(rng), noise(rng), noise(rng));
    const MeasuredPoint x = cmm::planner::measure_edge_two_touch(c.input);
    worst = std::max(worst, (x.position - c.wedge.apex).norm());
  }
  return worst * 1000;
}

TEST(TwoTouchEdge, WorstCaseUnderTriggerNoiseMatchesTheDesignFigures) {
  std::mt19937 rng(2024);
  const double wide = worst_error_um(rng, 0);
  const double narrow = worst_error_um(rng, 2 * deg);
  std::printf("two-touch worst error of 20000 cases, 1 um trigger noise, beta = 0.9 phi: "
              "phi >= 20 deg: %.1f um; phi = 2 deg: %.1f um\n", wide, narrow);
  RecordProperty("worst_error_phi20_um", std::to_string(wide));
  RecordProperty("worst_error_phi2_um", std::to_string(narrow));
  // Sideways the error is (ε1 − ε2)/(2 sin β): σ 2.3 µm at β = 18°, 22 µm at 1.8°; the worst of
  // 20,000 lies near 4σ. DESIGN.md quotes ≈ 7 µm and ≈ 86 µm.
  EXPECT_GT(wide, 5);
  EXPECT_LT(wide, 12);
  EXPECT_GT(narrow, 60);
  EXPECT_LT(narrow, 140);
}

// Sample covariance of the measured point over `trials` noisy repeats of one case, against the
// prediction, along the predicted principal directions in the plane.
void expect_predicted_sigma(const Case& base, int trials, double tolerance, std::mt19937& rng) {
  std::normal_distribution<double> noise(0, base.input.trigger_sigma_mm);
  const MeasuredPoint predicted = cmm::planner::measure_edge_two_touch(base.input);
  Eigen::Matrix3d sample = Eigen::Matrix3d::Zero();
  for (int k = 0; k < trials; ++k) {
    TwoTouchInput noisy = base.input;
    for (Vec3& centre : noisy.centre) centre += Vec3(noise(rng), noise(rng), noise(rng));
    const Vec3 e = cmm::planner::measure_edge_two_touch(noisy).position - predicted.position;
    sample += e * e.transpose();
  }
  sample /= trials;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(predicted.covariance);
  for (int k = 1; k < 3; ++k) {  // the two in-plane directions; the third is along the tangent, ≈ 0
    const Vec3 v = eigen.eigenvectors().col(k);
    const double want = std::sqrt(eigen.eigenvalues()(k)), got = std::sqrt(v.dot(sample * v));
    EXPECT_NEAR(got / want, 1, tolerance) << "direction " << k << ": predicted " << want * 1000 << " um, Monte-Carlo "
                                          << got * 1000 << " um";
  }
  EXPECT_LT(eigen.eigenvalues()(0), 1e-20);
  EXPECT_NEAR(predicted.sigma_mm, std::sqrt(eigen.eigenvalues()(2)), 1e-15);
}

TEST(TwoTouchEdge, PredictedUncertaintyAgreesWithMonteCarlo) {
  std::mt19937 rng(5);
  for (const double beta : {3.0, 18.0, 40.0, 65.0}) {
    const double alpha = 30 * deg, r = 1.5, delta = 0.2;
    ASSERT_LE(beta * deg, half_angle(alpha, r, delta));
    Case c = make_case(rng, alpha, r, delta, beta * deg);
    c.input.trigger_sigma_mm = 0.001;
    SCOPED_TRACE("beta " + std::to_string(beta));
    expect_predicted_sigma(c, 4000, 0.10, rng);
    const MeasuredPoint x = cmm::planner::measure_edge_two_touch(c.input);
    std::printf("two-touch beta %4.0f deg: predicted sigma %.2f um (1/sin beta = %.2f)\n", beta, x.sigma_mm * 1000,
                x.sensitivity);
  }
}

TEST(TwoTouchEdge, GrazingCirclesAreClampedAndMissingOnesRefused) {
  const double r = 1;
  TwoTouchInput in;
  in.id = 42;
  in.reference_point = Vec3(0, 0, 0);
  in.tangent = Vec3::UnitZ();
  in.window_axis = -Vec3::UnitY();
  in.ball_radius_mm = r;
  in.approach[0] = Vec3(1, -1, 0).normalized();
  in.approach[1] = Vec3(-1, -1, 0).normalized();
  // Centres 2r + 2 µm apart (within 4√2σ = 5.7 µm): tangency at their midpoint.
  in.centre[0] = Vec3(-(r + 0.001), 0.3, 0);
  in.centre[1] = Vec3(r + 0.001, 0.3, 0);
  const MeasuredPoint x = cmm::planner::measure_edge_two_touch(in);
  EXPECT_TRUE(x.clamped);
  EXPECT_LT((x.position - Vec3(0, 0.3, 0)).norm(), 1e-12);
  EXPECT_FALSE(x.notes.empty());
  EXPECT_GT(x.sigma_mm, 0.05);  // √(r · 5.7 µm) ≈ 75 µm across the line of centres

  in.centre[0] = Vec3(-(r + 0.005), 0.3, 0);
  in.centre[1] = Vec3(r + 0.005, 0.3, 0);
  try {
    cmm::planner::measure_edge_two_touch(in);
    FAIL() << "circles 10 µm apart accepted";
  } catch (const CompensationError& e) {
    EXPECT_EQ(e.id(), 42);
    EXPECT_EQ(e.reason(), CompensationError::Reason::no_intersection);
    EXPECT_NE(std::string(e.what()).find("edge point 42:"), std::string::npos) << e.what();
  }
}

TEST(TwoTouchEdge, RefusesDegenerateAndNonFiniteInput) {
  TwoTouchInput in;
  in.id = 3;
  in.reference_point = Vec3::Zero();
  in.tangent = Vec3::UnitZ();
  in.window_axis = -Vec3::UnitY();
  in.ball_radius_mm = 1;
  in.approach = {-Vec3::UnitY(), -Vec3::UnitY()};
  in.centre = {Vec3(0, 1, 0), Vec3(0.1, 1, 0)};
  const auto reason = [&](const TwoTouchInput& input) {
    try {
      cmm::planner::measure_edge_two_touch(input);
    } catch (const CompensationError& e) {
      EXPECT_EQ(e.id(), 3);
      return e.reason();
    }
    ADD_FAILURE() << "accepted";
    return CompensationError::Reason::bad_input;
  };
  EXPECT_EQ(reason(in), CompensationError::Reason::degenerate);  // parallel approaches
  in.approach[1] = Vec3(1, -1, 0).normalized();
  in.centre[1] = in.centre[0];
  EXPECT_EQ(reason(in), CompensationError::Reason::degenerate);  // coincident centres
  in.centre[1] = Vec3(NAN, 0, 0);
  EXPECT_EQ(reason(in), CompensationError::Reason::bad_input);
  in.centre[1] = Vec3(0.5, 1, 0);
  in.ball_radius_mm = 0;
  EXPECT_EQ(reason(in), CompensationError::Reason::bad_input);
  in.ball_radius_mm = 1;
  in.approach[0] = Vec3::UnitZ();  // along the tangent: no direction in the cross-section
  EXPECT_EQ(reason(in), CompensationError::Reason::bad_input);
}

// ---- faces -----------------------------------------------------------------------------------------

// Touches on each face of `wedge` at distances along the face away from the edge and along it.
std::vector<Vec3> face_centres(const Wedge& w, int side, int count, double r, std::mt19937& rng) {
  // A spread pattern (never three on a line) with some jitter.
  constexpr double away[] = {1, 3, 2, 1.5}, along[] = {-2, -1, 2, 0.5};
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);
  const Vec3 n = w.normal(side);
  const Vec3 in_face = w.tangent.cross(n).normalized();  // across the edge in the face's plane
  std::vector<Vec3> centres;
  for (int i = 0; i < count; ++i) {
    centres.push_back(w.apex + (away[i] + jitter(rng)) * in_face + (along[i] + jitter(rng)) * w.tangent + r * n);
  }
  return centres;
}

// Turns `v` by `angle` about a random axis perpendicular to it.
Vec3 tilt(const Vec3& v, double angle, std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Vec3 axis = v.cross(Vec3(normal(rng), normal(rng), normal(rng))).normalized();
  return Eigen::AngleAxisd(angle, axis) * v;
}

TEST(FaceEdge, RecoversTheEdgeOfExactPlanesConvexAndConcave) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0, 1), offset(-0.5, 0.5);
  for (int k = 0; k < 150; ++k) {
    // α over 30–330°: above 180° the edge is concave; the planes do not care.
    const double alpha = (30 + 300 * unit(rng)) * deg;
    if (std::abs(alpha - std::numbers::pi) < 10 * deg) continue;
    const Wedge w = random_wedge(rng, alpha);
    const double r = 0.5 + 2 * unit(rng);
    const int touches = 1 + k % 4;  // 1–4 per face
    FaceEdgeInput in;
    in.id = k;
    in.ball_radius_mm = r;
    in.reference_point = w.apex + Vec3(offset(rng), offset(rng), offset(rng));
    in.up.centres = face_centres(w, 0, touches, r, rng);
    in.down.centres = face_centres(w, 1, touches, r, rng);
    // Three or more touches fit the plane, so a nominal normal 3° off must not matter.
    in.up.nominal_normal = touches >= 3 ? tilt(w.normal(0), 3 * deg, rng) : w.normal(0);
    in.down.nominal_normal = touches >= 3 ? tilt(w.normal(1), 3 * deg, rng) : w.normal(1);
    in.tangent = w.normal(0).cross(w.normal(1)).normalized();
    const MeasuredPoint x = cmm::planner::measure_edge_from_faces(in);
    const Vec3 expected = w.apex + (in.reference_point - w.apex).dot(w.tangent) * w.tangent;
    ASSERT_LT((x.position - expected).norm(), 1e-9) << "alpha " << alpha / deg << " touches " << touches;
    EXPECT_GT(x.tangent.dot(in.tangent), 1 - 1e-9);
    // Two touches fit the face's tilt along their line; one takes the nominal normal as exact.
    EXPECT_EQ(x.notes.empty(), touches >= 2) << (x.notes.empty() ? "" : x.notes[0]);
  }
}

TEST(FaceEdge, ConcaveInnerCornerOfAnLShape) {
  // Material x < 0 or z < 0: floor z = 0 (normal +z) for x > 0, wall x = 0 (normal +x) for z > 0.
  const double r = 1;
  FaceEdgeInput in;
  in.id = 9;
  in.ball_radius_mm = r;
  in.reference_point = Vec3(0.1, 2, -0.05);
  in.up.nominal_normal = Vec3::UnitZ();
  in.up.centres = {Vec3(2, 1, r), Vec3(3, 4, r)};
  in.down.nominal_normal = Vec3::UnitX();
  in.down.centres = {Vec3(r, 2, 2)};
  in.tangent = Vec3::UnitZ().cross(Vec3::UnitX());
  const MeasuredPoint x = cmm::planner::measure_edge_from_faces(in);
  EXPECT_LT((x.position - Vec3(0, 2, 0)).norm(), 1e-12);
  EXPECT_EQ(x.method, cmm::planner::MeasurementMethod::face_intersection);
  // Faces at 90°. The floor's two touches fit its tilt along their line (1, 3, 0)/√10: its height at
  // the edge (0, 2) is extrapolated from them, 0.9 z₁ + 0.1 z₂. The wall's one touch takes its
  // nominal normal and moves the point along it by its own noise.
  const double s = 0.001;
  EXPECT_NEAR(x.covariance(2, 2), (0.81 + 0.01) * s * s, 1e-12);
  EXPECT_NEAR(x.covariance(0, 0), s * s, 1e-12);
  EXPECT_NEAR(x.covariance(1, 1), 0, 1e-9);
  ASSERT_EQ(x.notes.size(), 1u);
  EXPECT_NE(x.notes[0].find("nominal normal taken as exact"), std::string::npos) << x.notes[0];
}

TEST(FaceEdge, TwoTouchesAcrossTheEdgeCorrectANominalNormalTiltedAcrossIt) {
  // A 90° edge along y: top z = 0 (normal +z) for x < 0, side x = 0 (normal +x) for z < 0. The plan's
  // normals are 3° off about the edge (a scan's side normals are no better); two touches across the
  // edge on each face measure that tilt, and the edge comes out exact.
  const double r = 1, tilt_rad = 3 * deg;
  FaceEdgeInput in;
  in.id = 4;
  in.ball_radius_mm = r;
  in.reference_point = Vec3(0.05, 1, 0.05);
  in.up.nominal_normal = Eigen::AngleAxisd(tilt_rad, Vec3::UnitY()) * Vec3::UnitZ();
  in.up.centres = {Vec3(-1, 1, r), Vec3(-2.5, 1, r)};
  in.down.nominal_normal = Eigen::AngleAxisd(-tilt_rad, Vec3::UnitY()) * Vec3::UnitX();
  in.down.centres = {Vec3(r, 1, -1), Vec3(r, 1, -2.5)};
  in.tangent = Vec3::UnitY();
  const MeasuredPoint x = cmm::planner::measure_edge_from_faces(in);
  EXPECT_LT((x.position - Vec3(0, 1, 0)).norm(), 1e-12) << x.position.transpose();
  EXPECT_TRUE(x.notes.empty()) << x.notes.front();
}

TEST(FaceEdge, PredictedUncertaintyOfFittedFacesAgreesWithMonteCarlo) {
  std::mt19937 rng(8);
  const Wedge w = random_wedge(rng, 100 * deg);
  const double r = 1, sigma = 0.001;
  FaceEdgeInput in;
  in.id = 1;
  in.ball_radius_mm = r;
  in.reference_point = w.apex;
  in.up = {face_centres(w, 0, 4, r, rng), w.normal(0)};
  in.down = {face_centres(w, 1, 3, r, rng), w.normal(1)};
  in.tangent = w.tangent;
  const MeasuredPoint predicted = cmm::planner::measure_edge_from_faces(in);
  // The trials take the point without its (numerical, costly) uncertainty: the same planes and
  // intersection, as the first check shows.
  const auto point_of = [&](const FaceEdgeInput& input) {
    const auto up = cmm::planner::fit_face_plane(input.up, r, sigma, input.id, "up");
    const auto down = cmm::planner::fit_face_plane(input.down, r, sigma, input.id, "down");
    EXPECT_TRUE(up.normal_fitted && down.normal_fitted);
    return cmm::planner::face_edge_point(up, down, input.reference_point, input.id);
  };
  EXPECT_LT((point_of(in) - predicted.position).norm(), 1e-12);
  std::normal_distribution<double> noise(0, sigma);
  Eigen::Matrix3d sample = Eigen::Matrix3d::Zero();
  const int trials = 2000;
  for (int k = 0; k < trials; ++k) {
    FaceEdgeInput noisy = in;
    for (auto* face : {&noisy.up, &noisy.down}) {
      for (Vec3& c : face->centres) c += Vec3(noise(rng), noise(rng), noise(rng));
    }
    const Vec3 e = point_of(noisy) - predicted.position;
    sample += e * e.transpose();
  }
  sample /= trials;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(predicted.covariance);
  for (int k = 1; k < 3; ++k) {
    const Vec3 v = eigen.eigenvectors().col(k);
    EXPECT_NEAR(std::sqrt(v.dot(sample * v) / eigen.eigenvalues()(k)), 1, 0.10) << "direction " << k;
  }
  std::printf("faces (4 + 3 touches, 100 deg edge): predicted sigma %.2f um, Monte-Carlo %.2f um\n",
              predicted.sigma_mm * 1000,
              std::sqrt(eigen.eigenvectors().col(2).dot(sample * eigen.eigenvectors().col(2))) * 1000);
}

TEST(FaceEdge, RefusesParallelFacesAndMissingTouches) {
  FaceEdgeInput in;
  in.id = 12;
  in.ball_radius_mm = 1;
  in.up = {{Vec3(0, 0, 1)}, Vec3::UnitZ()};
  in.down = {{Vec3(5, 0, 1)}, Vec3::UnitZ()};
  try {
    cmm::planner::measure_edge_from_faces(in);
    FAIL();
  } catch (const CompensationError& e) {
    EXPECT_EQ(e.reason(), CompensationError::Reason::degenerate);
    EXPECT_NE(std::string(e.what()).find("edge point 12"), std::string::npos);
  }
  in.down.centres.clear();
  EXPECT_THROW(cmm::planner::measure_edge_from_faces(in), CompensationError);
}

// ---- deviation and frames ----------------------------------------------------------------------------

TEST(SignedDeviation, PositiveOutsideNegativeInsideTangentIgnored) {
  // A 90° convex edge along x: top face +z, front face −y; outward bisector (0, −1, 1)/√2.
  const Vec3 n_up = Vec3::UnitZ(), n_down = -Vec3::UnitY(), t = n_up.cross(n_down);
  const Vec3 a(10, 5, 3), b = (n_up + n_down).normalized();
  const EdgeDeviation out = cmm::planner::signed_deviation(a + 0.02 * b + 7 * t, a, n_up, n_down, t);
  EXPECT_NEAR(out.signed_mm, 0.02, 1e-12);
  EXPECT_NEAR(out.outward_mm, 0.02, 1e-12);
  EXPECT_NEAR(out.sideways_mm, 0, 1e-12);
  EXPECT_LT((out.vector - 0.02 * b).norm(), 1e-12);
  const EdgeDeviation in = cmm::planner::signed_deviation(a - 0.03 * b, a, n_up, n_down, t);
  EXPECT_NEAR(in.signed_mm, -0.03, 1e-12);
  // Off the bisector: the magnitude of the whole cross-section part, signed by its outward component.
  const Vec3 across = t.cross(b);
  const EdgeDeviation skew = cmm::planner::signed_deviation(a - 0.03 * b + 0.04 * across, a, n_up, n_down, t);
  EXPECT_NEAR(skew.signed_mm, -0.05, 1e-12);
  EXPECT_NEAR(skew.sideways_mm, 0.04, 1e-12);
  EXPECT_THROW(cmm::planner::signed_deviation(a, a, n_up, -n_up, t), CompensationError);
}

TEST(ScanFrame, MapsPointsVectorsAndCovariancesBack) {
  std::mt19937 rng(4);
  Eigen::Isometry3d T_M_S = Eigen::Isometry3d::Identity();
  T_M_S.linear() = random_rotation(rng);
  T_M_S.translation() = Vec3(120, -40, 300);
  const Vec3 p_S(1, 2, 3), t_S = Vec3(1, 1, 0).normalized();
  Eigen::Matrix3d cov_S = Eigen::Matrix3d::Zero();
  cov_S(0, 0) = 4e-6;
  cov_S(1, 1) = 1e-6;
  MeasuredPoint m;
  m.id = 5;
  m.position = T_M_S * p_S;
  m.tangent = T_M_S.linear() * t_S;
  m.covariance = T_M_S.linear() * cov_S * T_M_S.linear().transpose();
  m.sigma_mm = 0.002;
  const MeasuredPoint s = cmm::planner::to_scan_frame(m, T_M_S);
  EXPECT_EQ(s.frame, PointFrame::scan);
  EXPECT_LT((s.position - p_S).norm(), 1e-12);
  EXPECT_LT((s.tangent - t_S).norm(), 1e-12);
  EXPECT_LT((s.covariance - cov_S).norm(), 1e-18);
  EXPECT_EQ(s.sigma_mm, m.sigma_mm);
  EXPECT_THROW(cmm::planner::to_scan_frame(s, T_M_S), CompensationError);
}

}  // namespace
