// Rigid least-squares fit between paired points (Umeyama, no scale) with its residuals and the
// uncertainty the point geometry and the stated coordinate noise predict for it.
#pragma once

#include <span>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/mesh.hpp"

namespace cmm::planner {

using geometry::Vec3;

// T_to_from = argmin Σ |to_i − (R from_i + t)|², R a proper rotation.
struct RigidFit {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();  // maps `from` coordinates into `to`
  std::vector<Vec3> residuals;  // to_i − T·from_i, in the `to` frame, mm
  std::vector<double> residual_norms;  // |residual_i|, mm
  double rms_mm = 0;  // sqrt(mean |residual_i|²)
};

// Eigen::umeyama(from, to, false). Umeyama's sign correction keeps det R = +1 even when the best
// orthogonal map would be a reflection; the result is checked again here. Throws
// std::invalid_argument for fewer than three pairs or sizes that differ: callers name bad input
// (which corner, which frame) before they get here.
RigidFit fit_rigid(std::span<const Vec3> from, std::span<const Vec3> to);

// Predicted uncertainty of a rigid fit from the linearised least squares, for isotropic independent
// noise of σ_from and σ_to per coordinate on the two point sets.
//
// Parameters (6): a small rotation vector ω in the `to` frame's axes, applied on the left
// (R = exp([ω]×) R_fit), then the error of c = T·centroid_from, the image of the `from` points'
// centroid. Expressed there, the normal matrix is block diagonal:
//   JᵀJ = diag( Σ (|p_i|² I − p_i p_iᵀ), N I ),  p_i = R_fit (from_i − centroid_from),
//   Σ = σ_eff² (JᵀJ)⁻¹,  σ_eff² = σ_from² + σ_to²
// (the `from` noise enters each residual as R e_from, isotropic, so it just adds).
struct RigidFitUncertainty {
  double sigma_from_mm = 0, sigma_to_mm = 0, sigma_eff_mm = 0;
  int pairs = 0;
  Vec3 centroid_from = Vec3::Zero();             // where the translation part is expressed, `from` frame
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  // [ω rad, c mm]
  Eigen::Matrix3d rotation_covariance = Eigen::Matrix3d::Zero();  // rad²
  Vec3 rotation_std_rad = Vec3::Zero();            // per axis of the `to` frame
  double rotation_rms_rad = 0;                     // sqrt(trace Σ_ωω): RMS of |ω|
  double translation_rms_at_centroid_mm = 0;       // RMS of |δ(T·centroid_from)| = σ_eff sqrt(3/N)
  double translation_rms_at_origin_mm = 0;         // RMS of |δ(T·0)| = RMS error of t
  double expected_rms_mm = 0;                      // E of the fit's residual RMS: σ_eff sqrt((3N − 6)/N)
};

// Throws std::invalid_argument when the points are collinear (the rotation about their line is free).
RigidFitUncertainty predict_rigid_fit_uncertainty(std::span<const Vec3> from, const Eigen::Isometry3d& transform,
                                                  double sigma_from_mm, double sigma_to_mm);

// Covariance (mm², `to` frame) of the fitted transform's image of `point_from`:
// δ(T x) = δc − [R_fit (x − centroid_from)]× ω.
Eigen::Matrix3d predicted_point_covariance(const RigidFitUncertainty& uncertainty, const Eigen::Isometry3d& transform,
                                           const Vec3& point_from);

}  // namespace cmm::planner
