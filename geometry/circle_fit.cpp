// Kasa's algebraic fit seeds a Gauss–Newton geometric fit: the algebraic one alone is biased
// toward small radii on short arcs and noisy rims.
#include "geometry/circle_fit.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace cmm::geometry {

Circle3 fit_circle(const std::vector<Vec3>& points) {
  Circle3 circle;
  const int n = static_cast<int>(points.size());
  if (n < 3) return circle;
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : points) mean += p;
  mean /= n;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Vec3& p : points) covariance += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
  const Vec3 u = eigen.eigenvectors().col(2), v = eigen.eigenvectors().col(1);
  circle.normal = eigen.eigenvectors().col(0);
  if (eigen.eigenvalues()(1) <= 1e-18 * std::max(1.0, eigen.eigenvalues()(2))) return circle;

  std::vector<Eigen::Vector2d> planar(n);
  double out_of_plane = 0;
  for (int i = 0; i < n; ++i) {
    const Vec3 d = points[i] - mean;
    planar[i] = {d.dot(u), d.dot(v)};
    out_of_plane += std::pow(d.dot(circle.normal), 2);
  }
  // Kasa: x² + y² + D x + E y + F = 0, linear least squares.
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    a.row(i) << planar[i].x(), planar[i].y(), 1.0;
    b(i) = -planar[i].squaredNorm();
  }
  const Eigen::Vector3d kasa = a.colPivHouseholderQr().solve(b);
  Eigen::Vector2d c(-kasa(0) / 2, -kasa(1) / 2);
  double r = std::sqrt(std::max(0.0, c.squaredNorm() - kasa(2)));

  // Gauss–Newton on residuals |p − c| − r.
  for (int iteration = 0; iteration < 20; ++iteration) {
    Eigen::MatrixXd j(n, 3);
    Eigen::VectorXd residual(n);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d d = planar[i] - c;
      const double distance = std::max(d.norm(), 1e-300);
      residual(i) = distance - r;
      j.row(i) << -d.x() / distance, -d.y() / distance, -1.0;
    }
    const Eigen::Vector3d step = j.colPivHouseholderQr().solve(-residual);
    c += step.head<2>();
    r += step(2);
    if (step.norm() < 1e-12 * std::max(1.0, r)) break;
  }

  double sum_squares = 0, low = INFINITY, high = -INFINITY;
  for (const auto& p : planar) {
    const double radial = (p - c).norm();
    sum_squares += (radial - r) * (radial - r);
    low = std::min(low, radial);
    high = std::max(high, radial);
  }
  circle.centre = mean + c.x() * u + c.y() * v;
  circle.radius = r;
  circle.rms_mm = std::sqrt(sum_squares / n);
  circle.roundness_mm = high - low;
  circle.out_of_plane_mm = std::sqrt(out_of_plane / n);
  return circle;
}

}  // namespace cmm::geometry
