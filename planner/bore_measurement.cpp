// The ball centres of a bore lie on a circle r smaller than the hole, so the circle is fitted to the
// centres and r added at the end. Kåsa alone is biased toward small radii on short arcs and noise;
// Gauss–Newton on the geometric residuals removes that and its Jacobian gives the uncertainty.
#include "planner/bore_measurement.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <sstream>

namespace cmm::planner {

namespace {

using Reason = CompensationError::Reason;

std::string mm(double value) {
  std::ostringstream out;
  out.precision(6);
  out << value << " mm";
  return out.str();
}

}  // namespace

BoreMeasurement measure_bore(const BoreInput& in) {
  const auto refuse = [&](Reason reason, const std::string& message) {
    return CompensationError("hole", in.hole_id, reason, message);
  };
  const int n = static_cast<int>(in.centres.size());
  if (n < 3) {
    throw refuse(Reason::bad_input, std::to_string(n) + " bore touch(es); a circle needs at least 3");
  }
  for (int i = 0; i < n; ++i) {
    if (!in.centres[i].allFinite()) throw refuse(Reason::bad_input, "bore touch " + std::to_string(i + 1) + " is not finite");
  }
  if (!(in.ball_radius_mm > 0) || !std::isfinite(in.ball_radius_mm)) {
    throw refuse(Reason::bad_input, "ball radius " + mm(in.ball_radius_mm) + " is not positive");
  }
  if (!(in.trigger_sigma_mm >= 0) || !std::isfinite(in.trigger_sigma_mm)) {
    throw refuse(Reason::bad_input, "trigger noise " + mm(in.trigger_sigma_mm) + " is not a standard deviation");
  }
  const double axis_norm = in.axis.norm();
  if (!std::isfinite(axis_norm) || axis_norm < 1e-9) throw refuse(Reason::bad_input, "the hole axis is zero or not finite");
  const Vec3 axis = in.axis / axis_norm;

  // Plane across the axis through the touches' mean; u, v span it.
  Vec3 mean = Vec3::Zero();
  for (const Vec3& c : in.centres) mean += c;
  mean /= n;
  const Vec3 u = axis.unitOrthogonal();
  const Vec3 v = axis.cross(u);
  std::vector<Eigen::Vector2d> planar(n);
  double depth_low = INFINITY, depth_high = -INFINITY;
  for (int i = 0; i < n; ++i) {
    const Vec3 d = in.centres[i] - mean;
    planar[i] = {d.dot(u), d.dot(v)};
    depth_low = std::min(depth_low, d.dot(axis));
    depth_high = std::max(depth_high, d.dot(axis));
  }

  // Touches on one line fix no circle: the smaller principal spread of the planar points vanishes
  // next to the larger one (eigenvalues of the symmetric 2 × 2 scatter in closed form).
  double sxx = 0, sxy = 0, syy = 0;
  for (const auto& p : planar) {
    sxx += p.x() * p.x();
    sxy += p.x() * p.y();
    syy += p.y() * p.y();
  }
  const double half_trace = (sxx + syy) / 2, radius = std::hypot((sxx - syy) / 2, sxy);
  if (!(half_trace - radius > 1e-12 * std::max(half_trace + radius, 1e-300))) {
    throw refuse(Reason::degenerate, "the " + std::to_string(n) + " bore touches lie on one line across the axis");
  }

  // Kåsa: x² + y² + D x + E y + F = 0, linear least squares through its 3 × 3 normal equations
  // (the points are centred, so they are well scaled; the result only seeds the geometric fit).
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d right = Eigen::Vector3d::Zero();
  for (const auto& p : planar) {
    const Eigen::Vector3d row(p.x(), p.y(), 1.0);
    normal += row * row.transpose();
    right -= row * p.squaredNorm();
  }
  // 3 × 3 inverses are closed-form (cofactors) in Eigen: cheap, also in unoptimised test builds.
  const Eigen::Vector3d kasa = normal.inverse() * right;
  Eigen::Vector2d c(-kasa(0) / 2, -kasa(1) / 2);
  double rho = std::sqrt(std::max(0.0, c.squaredNorm() - kasa(2)));

  // Gauss–Newton on the residuals |p − c| − ρ, through the 3 × 3 normal equations: their
  // conditioning only slows the steps, the fixed point (Jᵀ res = 0) is computed from the residuals.
  Eigen::VectorXd residual(n);
  Eigen::Matrix3d information;
  const auto linearise = [&]() {
    information.setZero();
    Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d d = planar[i] - c;
      const double distance = std::max(d.norm(), 1e-300);
      residual(i) = distance - rho;
      const Eigen::Vector3d j(-d.x() / distance, -d.y() / distance, -1.0);
      information += j * j.transpose();
      gradient += j * residual(i);
    }
    return gradient;
  };
  // Touches close together leave the fit ill-conditioned and its last steps at rounding level
  // rather than below 1e-13 ρ; a last step under 1e-8 ρ (10 pm on a 1 mm bore) is converged.
  double last_step = INFINITY;
  for (int iteration = 0; iteration < 50; ++iteration) {
    const Eigen::Vector3d gradient = linearise();
    const Eigen::Vector3d step = -(information.inverse() * gradient);
    if (!step.allFinite()) break;
    c += step.head<2>();
    rho += step(2);
    last_step = step.norm();
    if (last_step < 1e-13 * std::max(1.0, std::abs(rho))) break;
  }
  if (!(last_step < 1e-8 * std::max(1.0, std::abs(rho))) || !(rho > 0) || !c.allFinite()) {
    throw refuse(Reason::degenerate, "the circle fit to " + std::to_string(n) + " bore touches does not converge");
  }
  linearise();

  BoreMeasurement bore;
  bore.hole_id = in.hole_id;
  bore.axis = axis;
  bore.centre = mean + c.x() * u + c.y() * v;
  bore.diameter_mm = 2 * (rho + in.ball_radius_mm);
  bore.depth_spread_mm = depth_high - depth_low;
  bore.residuals_mm.assign(residual.data(), residual.data() + n);
  bore.roundness_mm = residual.maxCoeff() - residual.minCoeff();
  bore.rms_mm = std::sqrt(residual.squaredNorm() / n);

  // Each centre's noise enters through its radial component only (σ², per axis isotropic), so the
  // parameters' covariance is σ² (JᵀJ)⁻¹.
  const Eigen::Matrix3d parameters = in.trigger_sigma_mm * in.trigger_sigma_mm * information.inverse();
  Eigen::Matrix<double, 3, 2> basis;
  basis.col(0) = u;
  basis.col(1) = v;
  bore.centre_covariance = basis * parameters.topLeftCorner<2, 2>() * basis.transpose();
  const double centre_half_trace = (parameters(0, 0) + parameters(1, 1)) / 2;
  const double centre_radius = std::hypot((parameters(0, 0) - parameters(1, 1)) / 2, parameters(0, 1));
  bore.centre_sigma_mm = std::sqrt(std::max(0.0, centre_half_trace + centre_radius));
  bore.diameter_sigma_mm = 2 * std::sqrt(std::max(0.0, parameters(2, 2)));
  return bore;
}

std::vector<MeasuredPoint> bore_wall_points(const BoreInput& in, const BoreMeasurement& bore) {
  if (bore.frame != PointFrame::machine) {
    throw CompensationError("hole", in.hole_id, Reason::bad_input, "bore wall points need the bore in M, as its touches");
  }
  std::vector<MeasuredPoint> points;
  points.reserve(in.centres.size());
  for (std::size_t i = 0; i < in.centres.size(); ++i) {
    const Vec3 offset = in.centres[i] - bore.centre;
    const Vec3 radial = offset - offset.dot(bore.axis) * bore.axis;
    if (radial.norm() < 1e-12) {
      throw CompensationError("hole", in.hole_id, Reason::degenerate, "bore touch " + std::to_string(i + 1) + " lies on the axis");
    }
    MeasuredPoint point;
    point.id = in.hole_id;
    point.method = MeasurementMethod::bore_wall;
    point.position = in.centres[i] + in.ball_radius_mm * radial.normalized();
    point.tangent = bore.axis;
    point.covariance = in.trigger_sigma_mm * in.trigger_sigma_mm * Eigen::Matrix3d::Identity();
    point.sigma_mm = in.trigger_sigma_mm;
    points.push_back(point);
  }
  return points;
}

BoreMeasurement to_scan_frame(const BoreMeasurement& bore, const Eigen::Isometry3d& T_M_S) {
  if (bore.frame == PointFrame::scan) {
    throw CompensationError("hole", bore.hole_id, Reason::bad_input, "already in the scan frame: mapped twice?");
  }
  const Eigen::Matrix3d rotation_S_M = T_M_S.linear().transpose();
  BoreMeasurement mapped = bore;
  mapped.frame = PointFrame::scan;
  mapped.centre = T_M_S.inverse() * bore.centre;
  mapped.axis = rotation_S_M * bore.axis;
  mapped.centre_covariance = rotation_S_M * bore.centre_covariance * rotation_S_M.transpose();
  return mapped;
}

}  // namespace cmm::planner
