// Sphere fit: linear start (|p|² = 2c·p + k), then Gauss–Newton on |p − c| − R.
#include "hal/sphere_fit.hpp"

#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

namespace cmm::hal {

SphereFit fit_sphere(const std::vector<Vec3>& points) {
  const auto n = static_cast<Eigen::Index>(points.size());
  if (n < 4) throw std::invalid_argument("sphere fit: needs at least 4 points, got " + std::to_string(n));
  for (const auto& p : points)
    if (!p.allFinite()) throw std::invalid_argument("sphere fit: a point is not finite");

  Eigen::MatrixXd a(n, 4);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3& p = points[static_cast<std::size_t>(i)];
    a.row(i) << 2 * p.x(), 2 * p.y(), 2 * p.z(), 1;
    b(i) = p.squaredNorm();
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  qr.setThreshold(1e-12);
  if (qr.rank() < 4) throw std::invalid_argument("sphere fit: the points lie on one plane or circle");
  Eigen::Vector4d x = qr.solve(b);
  SphereFit fit;
  fit.centre = x.head<3>();
  fit.radius = std::sqrt(std::max(0.0, x(3) + fit.centre.squaredNorm()));

  for (int iteration = 0; iteration < 50; ++iteration) {
    Eigen::MatrixXd j(n, 4);
    Eigen::VectorXd r(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      Vec3 d = points[static_cast<std::size_t>(i)] - fit.centre;
      double dist = d.norm();
      if (dist == 0) throw std::invalid_argument("sphere fit: a point coincides with the centre");
      r(i) = dist - fit.radius;
      j.row(i) << -d.transpose() / dist, -1;
    }
    Eigen::Vector4d step = j.colPivHouseholderQr().solve(-r);
    fit.centre += step.head<3>();
    fit.radius += step(3);
    if (step.norm() < 1e-12) break;
  }
  double sum = 0;
  for (const auto& p : points) sum += std::pow((p - fit.centre).norm() - fit.radius, 2);
  fit.residual_rms = std::sqrt(sum / static_cast<double>(n));
  return fit;
}

}  // namespace cmm::hal
