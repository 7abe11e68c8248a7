// Plane fit by the eigenvectors of the points' scatter (orthogonal least squares, exact for points
// on a plane), and plane intersections by the closed forms that keep their conditioning visible.
#include "planner/plane_fit.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace cmm::planner {
namespace {

std::string number(double value, const char* format = "%.3g") {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

}  // namespace

PlaneFit fit_plane(std::span<const Vec3> points, double min_spread_ratio) {
  if (points.size() < 3)
    throw PlaneFitError("a plane needs at least three points, got " + std::to_string(points.size()));
  Vec3 centroid = Vec3::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) throw PlaneFitError("point " + std::to_string(i + 1) + " is not finite");
    centroid += points[i];
  }
  centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Vec3& p : points) scatter += (p - centroid) * (p - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  const Eigen::Vector3d lambda = eigen.eigenvalues().cwiseMax(0.0);  // ascending
  PlaneFit fit;
  fit.centroid = centroid;
  fit.spread_ratio = lambda(2) > 0 ? std::sqrt(lambda(1) / lambda(2)) : 0.0;
  if (!(fit.spread_ratio >= min_spread_ratio))
    throw PlaneFitError("the points are collinear (spread ratio " + number(fit.spread_ratio) + " < " +
                        number(min_spread_ratio) + "): the plane's tilt about their line is undetermined");
  fit.plane.normal = eigen.eigenvectors().col(0).normalized();
  fit.plane.offset = fit.plane.normal.dot(centroid);
  double sum_squares = 0;
  for (const Vec3& p : points) {
    const double d = fit.plane.signed_distance(p);
    sum_squares += d * d;
    fit.max_abs_mm = std::max(fit.max_abs_mm, std::abs(d));
  }
  fit.rms_mm = std::sqrt(sum_squares / static_cast<double>(points.size()));
  return fit;
}

Plane oriented_along(const Plane& plane, const Vec3& direction) {
  if (plane.normal.dot(direction) >= 0) return plane;
  return Plane{-plane.normal, -plane.offset};
}

double intersection_conditioning(const Plane& a, const Plane& b, const Plane& c) {
  return std::abs(a.normal.dot(b.normal.cross(c.normal)));
}

Vec3 intersect_planes(const Plane& a, const Plane& b, const Plane& c, double min_conditioning) {
  const double det = a.normal.dot(b.normal.cross(c.normal));
  if (!(std::abs(det) >= min_conditioning))
    throw PlaneFitError("the three planes nearly share a direction (|n_a · (n_b × n_c)| = " +
                        number(std::abs(det)) + " < " + number(min_conditioning) +
                        "): their common point is undetermined");
  // Cramer's rule written with cross products: x = Σ d_i (n_j × n_k) / det.
  return (a.offset * b.normal.cross(c.normal) + b.offset * c.normal.cross(a.normal) +
          c.offset * a.normal.cross(b.normal)) /
         det;
}

Line3 intersect_planes(const Plane& a, const Plane& b, double min_sine) {
  const Vec3 u = a.normal.cross(b.normal);
  const double sine = u.norm();
  if (!(sine >= min_sine))
    throw PlaneFitError("the two planes are nearly parallel (sine of their angle " + number(sine) + " < " +
                        number(min_sine) + "): their common line is undetermined");
  // The point with n_a·p = d_a, n_b·p = d_b and u·p = 0.
  Line3 line;
  line.point = (a.offset * b.normal.cross(u) + b.offset * u.cross(a.normal)) / (sine * sine);
  line.direction = u / sine;
  return line;
}

}  // namespace cmm::planner
