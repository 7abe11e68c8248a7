// Plane fits and plane intersections: exact on exact points, honest about noise, and refusing
// collinear points and near-parallel planes with a message instead of a wild answer.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "planner/plane_fit.hpp"

namespace cmm::planner {
namespace {

using ::testing::HasSubstr;

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const PlaneFitError& e) {
    return e.what();
  }
  return "(no PlaneFitError)";
}

TEST(PlaneFit, ExactPointsGiveTheirPlane) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-100, 100);
  for (int trial = 0; trial < 20; ++trial) {
    const Vec3 normal = Vec3(u(rng), u(rng), u(rng)).normalized();
    const double offset = u(rng);
    const Vec3 e1 = normal.unitOrthogonal(), e2 = normal.cross(e1);
    std::vector<Vec3> points;
    for (int i = 0; i < 7; ++i) points.push_back(offset * normal + u(rng) * e1 + u(rng) * e2);
    const PlaneFit fit = fit_plane(points);
    const Plane plane = oriented_along(fit.plane, normal);
    EXPECT_NEAR((plane.normal - normal).norm(), 0, 1e-12);
    EXPECT_NEAR(plane.offset, offset, 1e-10);
    EXPECT_LT(fit.rms_mm, 1e-10);
    EXPECT_LT(fit.max_abs_mm, 1e-10);
    EXPECT_GT(fit.spread_ratio, 0.05);
  }
}

TEST(PlaneFit, NoisyPointsReportTheirScatter) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0, 0.01);
  std::uniform_real_distribution<double> u(-50, 50);
  std::vector<Vec3> points;
  for (int i = 0; i < 2000; ++i) points.emplace_back(u(rng), u(rng), 3 + noise(rng));
  const PlaneFit fit = fit_plane(points);
  EXPECT_NEAR(std::abs(fit.plane.normal.z()), 1, 1e-6);
  EXPECT_NEAR(fit.rms_mm, 0.01, 0.001);
}

TEST(PlaneFit, RefusesTooFewCollinearOrNonFinitePoints) {
  EXPECT_THAT(message_of([] { fit_plane(std::vector<Vec3>{Vec3::Zero(), Vec3::UnitX()}); }),
              HasSubstr("at least three points, got 2"));
  EXPECT_THAT(message_of([] { fit_plane(std::vector<Vec3>{Vec3::Zero(), Vec3(1, 1, 1), Vec3(2, 2, 2)}); }),
              HasSubstr("collinear"));
  // Nearly collinear: 1 µm off a 100 mm line.
  EXPECT_THAT(message_of([] { fit_plane(std::vector<Vec3>{Vec3::Zero(), Vec3(50, 0.001, 0), Vec3(100, 0, 0)}); }),
              HasSubstr("collinear"));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(message_of([&] { fit_plane(std::vector<Vec3>{Vec3::Zero(), Vec3(1, 0, 0), Vec3(0, nan, 0)}); }),
              HasSubstr("point 3 is not finite"));
}

TEST(PlaneFit, OrientedAlongFlipsNormalAndOffsetTogether) {
  const Plane plane{Vec3::UnitZ(), 5};
  const Plane flipped = oriented_along(plane, -Vec3::UnitZ());
  EXPECT_EQ(flipped.normal, -Vec3::UnitZ());
  EXPECT_EQ(flipped.offset, -5);
  const Vec3 p(1, 2, 5);
  EXPECT_EQ(flipped.signed_distance(p), 0);
  EXPECT_EQ(oriented_along(plane, Vec3::UnitZ()).offset, 5);
}

TEST(PlaneIntersection, ThreePlanesMeetAtTheirCommonPoint) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 50; ++trial) {
    const Vec3 corner = 300 * Vec3(u(rng), u(rng), u(rng));
    std::array<Plane, 3> planes;
    for (auto& p : planes) {
      p.normal = Vec3(u(rng), u(rng), u(rng)).normalized();
      p.offset = p.normal.dot(corner);
    }
    if (intersection_conditioning(planes[0], planes[1], planes[2]) < 0.05) continue;
    EXPECT_NEAR((intersect_planes(planes[0], planes[1], planes[2]) - corner).norm(), 0, 1e-9);
  }
  // A box corner: conditioning 1.
  const Plane x{Vec3::UnitX(), 200}, y{Vec3::UnitY(), 150}, z{Vec3::UnitZ(), 0};
  EXPECT_DOUBLE_EQ(intersection_conditioning(x, y, z), 1);
  EXPECT_NEAR((intersect_planes(x, y, z) - Vec3(200, 150, 0)).norm(), 0, 1e-12);
}

TEST(PlaneIntersection, RefusesPlanesThatNearlyShareADirection) {
  const Plane a{Vec3::UnitX(), 0}, b{Vec3::UnitY(), 0};
  const Plane c{Vec3(1, 1, 1e-4).normalized(), 0};  // almost in the pencil of a and b
  EXPECT_LT(intersection_conditioning(a, b, c), 1e-3);
  EXPECT_THAT(message_of([&] { intersect_planes(a, b, c); }), HasSubstr("nearly share a direction"));
  EXPECT_NO_THROW(intersect_planes(a, b, c, 1e-5));
}

TEST(PlaneIntersection, TwoPlanesMeetInALine) {
  const Plane top{Vec3::UnitZ(), 0};
  const Plane side{Vec3(1, 1, 0).normalized(), 10};
  const Line3 line = intersect_planes(top, side);
  EXPECT_NEAR(top.signed_distance(line.point), 0, 1e-12);
  EXPECT_NEAR(side.signed_distance(line.point), 0, 1e-12);
  EXPECT_NEAR(line.direction.norm(), 1, 1e-15);
  EXPECT_NEAR(line.direction.dot(top.normal), 0, 1e-15);
  EXPECT_NEAR(line.direction.dot(side.normal), 0, 1e-15);
  EXPECT_NEAR(line.point.dot(line.direction), 0, 1e-12);  // the point nearest the origin
  EXPECT_NEAR(line.point.norm(), 10, 1e-12);
  for (double s : {-50.0, 70.0}) {
    EXPECT_NEAR(top.signed_distance(line.point + s * line.direction), 0, 1e-12);
    EXPECT_NEAR(side.signed_distance(line.point + s * line.direction), 0, 1e-12);
  }
  const Plane almost{Vec3(1e-5, 0, 1).normalized(), 3};
  EXPECT_THAT(message_of([&] { intersect_planes(top, almost); }), HasSubstr("nearly parallel"));
}

}  // namespace
}  // namespace cmm::planner
