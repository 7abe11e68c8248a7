// Per-point PCA tangent plane and least-squares quadric over the k nearest neighbours (thesis §3.3,
// §3.5), with the principal curvatures, their standard error and whether the point is regular.
#include "geometry/local_surface.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <span>

#include "geometry/scan_noise.hpp"

namespace cmm::geometry {

namespace {

constexpr int quadric_terms = 6;
// Fewer points than this leave the residual too few degrees of freedom to tell a crease from noise.
constexpr int min_regular_support = 10;
// sqrt(λ_mid / λ_max) below this: the neighbourhood is a line (one scan stripe, a wire), no surface.
constexpr double min_line_ratio = 0.05;
// sqrt(λ_min / λ_mid) above this: no longer a height field over any plane (a corner, two sheets).
constexpr double max_plane_spread = 0.5;
// A neighbourhood that turns by more than a radian is too coarse for a quadric to describe.
constexpr double max_turn = 1.0;
// The normal equations are solved in coordinates scaled to the neighbourhood (|u|, |v| ≤ 1); a
// smaller reciprocal condition means the points do not determine all six terms (a line, a circle).
constexpr double min_rcond = 1e-9;
// Residual tests of fit_local_surfaces: a fit is irregular when its σ-estimate exceeds this many
// times the scan's noise AND its residual is more than this fraction of the quadric's own height
// over the neighbourhood (|k1|·r²/2). A quadric through a crease leaves 5–7 % of its height (the
// best parabola through |x| leaves 6 %), a smooth surface at these sizes well under 1 %; the noise
// clause keeps noisy flat faces, whose quadric is all noise, regular.
constexpr double residual_noise_factor = 2.5;
constexpr double crease_residual_fraction = 0.02;
// Below this fraction of the neighbourhood's radius a residual is rounding, not shape (an exact plane).
constexpr double numerical_residual_fraction = 1e-9;
constexpr int block = 4096;  // points between polls of the cancel check

using Terms = Eigen::Matrix<double, quadric_terms, 1>;
using Normal = Eigen::Matrix<double, quadric_terms, quadric_terms>;

struct Frame {
  Vec3 origin, u, v, n;
};

struct QuadricFit {
  bool ok = false;
  double scale = 0;  // the largest in-plane distance of a neighbour from the origin
  Terms coef = Terms::Zero();  // in scaled coordinates: 1, u, v, u², uv, v²
  Normal inverse = Normal::Zero();  // (XᵀX)⁻¹, scaled
  double rss = 0;  // mm²
};

Vec3 point(const Points& points, int id) { return points.row(id).transpose(); }

Frame make_frame(const Vec3& origin, const Vec3& normal, const Vec3& hint) {
  Frame f{origin, hint - hint.dot(normal) * normal, Vec3::Zero(), normal};
  if (!(f.u.norm() > 1e-6)) f.u = normal.unitOrthogonal();
  f.u.normalize();
  f.v = normal.cross(f.u);  // u × v = normal
  return f;
}

// `with_inverse`: only the fit whose curvature error is reported needs (XᵀX)⁻¹, the costliest step.
QuadricFit fit_quadric(const Points& points, std::span<const int> ids, const Frame& frame, bool with_inverse) {
  QuadricFit fit;
  for (int id : ids) {
    const Vec3 d = point(points, id) - frame.origin;
    const double u = d.dot(frame.u), v = d.dot(frame.v);
    fit.scale = std::max(fit.scale, u * u + v * v);
  }
  fit.scale = std::sqrt(fit.scale);
  if (!(fit.scale > 0) || !std::isfinite(fit.scale)) return fit;
  Normal xtx = Normal::Zero();
  Terms xtz = Terms::Zero();
  for (int id : ids) {
    const Vec3 d = point(points, id) - frame.origin;
    const double u = d.dot(frame.u) / fit.scale, v = d.dot(frame.v) / fit.scale;
    const Terms row = (Terms() << 1, u, v, u * u, u * v, v * v).finished();
    xtx += row * row.transpose();
    xtz += row * d.dot(frame.n);
  }
  const Eigen::LDLT<Normal> solver(xtx);
  if (solver.info() != Eigen::Success || !(solver.rcond() > min_rcond)) return fit;
  fit.coef = solver.solve(xtz);
  fit.inverse = with_inverse ? Normal(solver.solve(Normal::Identity())) : Normal(Normal::Zero());
  for (int id : ids) {
    const Vec3 d = point(points, id) - frame.origin;
    const double u = d.dot(frame.u) / fit.scale, v = d.dot(frame.v) / fit.scale;
    const Terms row = (Terms() << 1, u, v, u * u, u * v, v * v).finished();
    fit.rss += std::pow(row.dot(fit.coef) - d.dot(frame.n), 2);
  }
  fit.ok = fit.coef.allFinite() && fit.inverse.allFinite() && std::isfinite(fit.rss);
  return fit;
}

LocalSurface fit_ids(const Points& points, std::span<const int> ids) {
  LocalSurface s;
  s.neighbours = static_cast<int>(ids.size());
  if (ids.empty()) return s;
  const Vec3 self = point(points, ids[0]);
  s.origin = self;
  s.on_surface = self;
  for (int id : ids) s.radius_mm = std::max(s.radius_mm, (point(points, id) - self).norm());
  if (!std::isfinite(s.radius_mm)) s.radius_mm = 0;
  if (ids.size() < 3) return s;

  // PCA about the centroid; differences first, so coordinates of 10⁶ mm keep their digits.
  Vec3 centroid = Vec3::Zero();
  for (int id : ids) centroid += point(points, id) - self;
  centroid /= static_cast<double>(ids.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (int id : ids) {
    const Vec3 d = point(points, id) - self - centroid;
    covariance += d * d.transpose();
  }
  covariance /= static_cast<double>(ids.size());
  if (!covariance.allFinite()) return s;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pca(covariance);
  const Vec3 lambda = pca.eigenvalues().cwiseMax(0.0);  // ascending
  const Vec3 pca_normal = pca.eigenvectors().col(0), pca_major = pca.eigenvectors().col(2);
  s.plane_spread = lambda(1) > 0 ? std::sqrt(lambda(0) / lambda(1)) : 0.0;
  const double line_ratio = lambda(2) > 0 ? std::sqrt(lambda(1) / lambda(2)) : 0.0;

  // The "improved minimum distance" origin: the neighbour nearest the centroid.
  int origin_id = ids[0];
  double best = (self - self - centroid).squaredNorm();
  for (int id : ids) {
    const double d = (point(points, id) - self - centroid).squaredNorm();
    if (d < best) best = d, origin_id = id;
  }
  s.origin = point(points, origin_id);
  Frame frame = make_frame(s.origin, pca_normal, pca_major);
  s.normal = frame.n, s.u = frame.u, s.v = frame.v;
  if (ids.size() < static_cast<std::size_t>(quadric_terms)) return s;

  QuadricFit fit = fit_quadric(points, ids, frame, false);
  if (!fit.ok) return s;
  // The PCA plane is the chord plane of the patch, tilted against the tangent plane at an off-centre
  // origin: the slope terms absorb that, and one refit in the frame of the quadric's own normal there
  // leaves a, b, c as the true second-order terms (tangent frame, slope ≈ 0).
  {
    const double p = fit.coef(1) / fit.scale, q = fit.coef(2) / fit.scale;
    const Vec3 tilted = (frame.n - p * frame.u - q * frame.v).normalized();
    const Frame refined = make_frame(s.origin, tilted, frame.u);
    QuadricFit again = fit_quadric(points, ids, refined, true);
    if (again.ok) fit = again, frame = refined;
    else fit = fit_quadric(points, ids, frame, true);
  }
  s.normal = frame.n, s.u = frame.u, s.v = frame.v;
  {
    const Vec3 d = self - frame.origin;
    const double u = d.dot(frame.u) / fit.scale, v = d.dot(frame.v) / fit.scale;
    const Terms row = (Terms() << 1, u, v, u * u, u * v, v * v).finished();
    s.on_surface = self + (row.dot(fit.coef) - d.dot(frame.n)) * frame.n;
  }
  const double s2 = fit.scale * fit.scale;
  s.a = fit.coef(3) / s2, s.b = fit.coef(4) / s2, s.c = fit.coef(5) / s2;
  const int n = static_cast<int>(ids.size());
  s.residual_rms_mm = std::sqrt(fit.rss / n);

  // Principal curvatures of the graph at (0, 0): the shape operator I⁻¹·II with the (small) slope
  // left after the refit, II = Hessian / √(1 + p² + q²).
  const double p = fit.coef(1) / fit.scale, q = fit.coef(2) / fit.scale;
  Eigen::Matrix2d hessian;
  hessian << 2 * s.a, s.b, s.b, 2 * s.c;
  Eigen::Matrix2d first;
  first << 1 + p * p, p * q, p * q, 1 + q * q;
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix2d> shape(hessian / std::sqrt(1 + p * p + q * q), first);
  double k1 = shape.eigenvalues()(0), k2 = shape.eigenvalues()(1);
  if (std::abs(k2) > std::abs(k1)) std::swap(k1, k2);
  if (!std::isfinite(k1) || !std::isfinite(k2)) return s;
  s.k1 = k1, s.k2 = k2;

  // Standard error of k1: δk1 = e1ᵀ δH e1 along k1's direction e1, with the coefficients' covariance
  // σ̂²(XᵀX)⁻¹, σ̂² = RSS / (n − 6).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> directions(hessian);
  const int major = std::abs(directions.eigenvalues()(0)) >= std::abs(directions.eigenvalues()(1)) ? 0 : 1;
  const Eigen::Vector2d e = directions.eigenvectors().col(major);
  const Eigen::Vector3d gradient = Eigen::Vector3d(2 * e(0) * e(0), 2 * e(0) * e(1), 2 * e(1) * e(1)) / s2;
  if (n > quadric_terms) {
    const double variance = fit.rss / (n - quadric_terms) * gradient.dot(fit.inverse.bottomRightCorner<3, 3>() * gradient);
    s.curvature_sigma = std::sqrt(std::max(0.0, variance));
    if (!std::isfinite(s.curvature_sigma)) s.curvature_sigma = 0;
  }

  s.regular = n >= min_regular_support && line_ratio >= min_line_ratio && s.plane_spread <= max_plane_spread &&
              std::abs(s.k1) * s.radius_mm <= max_turn;
  return s;
}

}  // namespace

LocalSurface fit_local_surface(const Points& points, const std::vector<int>& neighbourhood) {
  return fit_ids(points, neighbourhood);
}

std::vector<LocalSurface> fit_local_surfaces(const Points& points, const CloudIndex& index,
                                             const LocalSurfaceOptions& options) {
  const int count = static_cast<int>(points.rows());
  std::vector<LocalSurface> fits(static_cast<std::size_t>(count));
  const auto k = static_cast<std::size_t>(std::max(options.neighbours, 1));
  // Each point's fit depends only on its own neighbourhood and lands in its own slot: the same result
  // on any number of threads.
  for (int start = 0; start < count; start += block) {
    options.cancel.throw_if_requested("local surface fits");
    const int end = std::min(count, start + block);
    tbb::parallel_for(tbb::blocked_range<int>(start, end, 256), [&](const tbb::blocked_range<int>& range) {
      std::vector<int> ids;
      std::vector<double> squared;
      for (int i = range.begin(); i < range.end(); ++i) {
        index.nearest(point(points, i), k, ids, squared);
        fits[static_cast<std::size_t>(i)] = fit_ids(points, ids);
      }
    });
  }
  // The residual test needs the scan's noise, which needs the fits: a crease's residual is far above
  // it and a sizeable part of its quadric's height.
  const double sigma = estimate_scan_noise(fits).sigma_mm;
  for (LocalSurface& fit : fits) {
    if (!fit.regular) continue;
    const double height = std::abs(fit.k1) * fit.radius_mm * fit.radius_mm / 2;
    if (residual_sigma(fit) > residual_noise_factor * sigma && fit.residual_rms_mm > crease_residual_fraction * height &&
        fit.residual_rms_mm > numerical_residual_fraction * fit.radius_mm)
      fit.regular = false;
  }
  return fits;
}

}  // namespace cmm::geometry
