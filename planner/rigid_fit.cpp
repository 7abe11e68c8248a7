// Umeyama's closed form for the fit; the uncertainty from the normal equations of the linearised
// problem, parametrised at the centroid so that rotation and translation decouple.
#include "planner/rigid_fit.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>
#include <string>

namespace cmm::planner {
namespace {

Eigen::Matrix3d skew(const Vec3& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

void check_pairs(std::size_t from, std::size_t to) {
  if (from != to)
    throw std::invalid_argument("rigid fit: " + std::to_string(from) + " source points but " + std::to_string(to) +
                                " destination points");
  if (from < 3) throw std::invalid_argument("rigid fit: needs at least three pairs, got " + std::to_string(from));
}

}  // namespace

RigidFit fit_rigid(std::span<const Vec3> from, std::span<const Vec3> to) {
  check_pairs(from.size(), to.size());
  const auto n = static_cast<Eigen::Index>(from.size());
  Eigen::Matrix3Xd src(3, n), dst(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    src.col(i) = from[static_cast<std::size_t>(i)];
    dst.col(i) = to[static_cast<std::size_t>(i)];
  }
  const Eigen::Matrix4d t = Eigen::umeyama(src, dst, false);
  RigidFit fit;
  fit.transform.linear() = t.topLeftCorner<3, 3>();
  fit.transform.translation() = t.topRightCorner<3, 1>();
  // Umeyama flips the smallest singular direction when det(U)·det(V) < 0, so a mirrored point set
  // yields the best proper rotation (with large residuals), never a reflection. Guard it anyway:
  // a reflection here would put the part upside down in M.
  if (!(fit.transform.linear().determinant() > 0.5))
    throw std::logic_error("rigid fit: Umeyama returned an improper rotation (det " +
                           std::to_string(fit.transform.linear().determinant()) + ")");
  double sum_squares = 0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    const Vec3 r = to[i] - fit.transform * from[i];
    fit.residuals.push_back(r);
    fit.residual_norms.push_back(r.norm());
    sum_squares += r.squaredNorm();
  }
  fit.rms_mm = std::sqrt(sum_squares / static_cast<double>(from.size()));
  return fit;
}

RigidFitUncertainty predict_rigid_fit_uncertainty(std::span<const Vec3> from, const Eigen::Isometry3d& transform,
                                                  double sigma_from_mm, double sigma_to_mm) {
  if (from.size() < 3) throw std::invalid_argument("rigid fit uncertainty: needs at least three points");
  RigidFitUncertainty u;
  u.pairs = static_cast<int>(from.size());
  u.sigma_from_mm = sigma_from_mm;
  u.sigma_to_mm = sigma_to_mm;
  const double var_eff = sigma_from_mm * sigma_from_mm + sigma_to_mm * sigma_to_mm;
  u.sigma_eff_mm = std::sqrt(var_eff);
  for (const Vec3& p : from) u.centroid_from += p;
  u.centroid_from /= static_cast<double>(from.size());

  // Rotation block of JᵀJ: each residual's Jacobian in ω is −[p_i]×, and (−[p]×)ᵀ(−[p]×) = |p|² I − p pᵀ.
  Eigen::Matrix3d normal_rotation = Eigen::Matrix3d::Zero();
  for (const Vec3& q : from) {
    const Vec3 p = transform.linear() * (q - u.centroid_from);
    normal_rotation += p.squaredNorm() * Eigen::Matrix3d::Identity() - p * p.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(normal_rotation);
  // Collinear points leave the rotation about their line free: the smallest eigenvalue vanishes.
  if (!(eigen.eigenvalues()(0) > 1e-12 * eigen.eigenvalues()(2)))
    throw std::invalid_argument("rigid fit uncertainty: the points are collinear");
  const Eigen::Matrix3d inverse = eigen.eigenvectors() * eigen.eigenvalues().cwiseInverse().asDiagonal() *
                                  eigen.eigenvectors().transpose();
  u.rotation_covariance = var_eff * inverse;
  u.covariance.topLeftCorner<3, 3>() = u.rotation_covariance;
  u.covariance.bottomRightCorner<3, 3>() = (var_eff / u.pairs) * Eigen::Matrix3d::Identity();
  u.rotation_std_rad = u.rotation_covariance.diagonal().cwiseSqrt();
  u.rotation_rms_rad = std::sqrt(u.rotation_covariance.trace());
  u.translation_rms_at_centroid_mm = std::sqrt(u.covariance.bottomRightCorner<3, 3>().trace());
  u.translation_rms_at_origin_mm = std::sqrt(predicted_point_covariance(u, transform, Vec3::Zero()).trace());
  u.expected_rms_mm = std::sqrt(var_eff * (3.0 * u.pairs - 6.0) / u.pairs);
  return u;
}

Eigen::Matrix3d predicted_point_covariance(const RigidFitUncertainty& u, const Eigen::Isometry3d& transform,
                                           const Vec3& point_from) {
  // δ(T x) = δc + ω × R(x − c̄) = δc − [R(x − c̄)]× ω; the ω–c blocks are zero.
  const Eigen::Matrix3d a = -skew(transform.linear() * (point_from - u.centroid_from));
  return u.covariance.bottomRightCorner<3, 3>() + a * u.rotation_covariance * a.transpose();
}

}  // namespace cmm::planner
