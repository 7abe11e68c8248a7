// Per point of a raw scan, the local surface its k nearest neighbours describe (thesis §3.3, §3.5):
// a tangent plane by PCA and the quadric S(u,v) = a·u² + b·uv + c·v² over it, with the fit's residual,
// principal curvatures and whether the point is regular enough to speak for the surface's curvature.
#pragma once

#include <vector>

#include "geometry/cancellation.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct LocalSurface {
  // The neighbour nearest the neighbourhood's centroid (the thesis's "improved minimum distance"
  // origin): the quadric's origin and tangent frame sit there, not at the point itself.
  Vec3 origin = Vec3::Zero();
  // Unit, sign not yet oriented: the fitted quadric's normal at the origin (PCA's least-variance axis
  // tilted by the quadric's slope there, so the frame below is a true tangent frame).
  Vec3 normal = Vec3::UnitZ();
  Vec3 u = Vec3::UnitX(), v = Vec3::UnitY();  // tangent frame, u × v = normal
  // S(u,v) along `normal`, mm⁻¹: the second-order terms of S = d + e·u + f·v + a·u² + b·uv + c·v²
  // (the constant and slopes are fitted too, so a noisy origin or a tilted plane does not bias them).
  // The second derivatives are S_uu = 2a, S_uv = b, S_vv = 2c.
  double a = 0, b = 0, c = 0;
  // The point itself moved along `normal` onto the fitted quadric: its position with the noise the
  // fit averages out (a regular fit's residual is the scan's noise; this is off by about σ·√(6/k)).
  Vec3 on_surface = Vec3::Zero();
  double k1 = 0, k2 = 0;                       // principal curvatures at the origin, |k1| ≥ |k2|, 1/mm
  double curvature_sigma = 0;                  // standard error of k1 from the fit's residual, 1/mm
  double residual_rms_mm = 0;                  // RMS distance of the neighbours from the quadric
  double plane_spread = 0;                     // sqrt(λ_min / λ_mid) of the PCA: 0 on a plane
  double radius_mm = 0;                        // distance from the point to its k-th neighbour
  int neighbours = 0;                          // points the fit used (its residual has neighbours − 6 degrees of freedom)
  // False on a crease, a corner, an outlier or a too-thin neighbourhood (fit residual and normal
  // spread tell them): such points say nothing about the smooth surface's curvature.
  // fit_local_surface judges the neighbourhood's shape alone (well posed, not a line, a height field);
  // fit_local_surfaces also clears it where the residual is far above the whole scan's noise.
  bool regular = false;
};

struct LocalSurfaceOptions {
  int neighbours = 25;
  CancelCheck cancel;  // polled between blocks of points
};

// One fit per point of `points`, in order, on both cores (oneTBB); the same result on any number of
// threads. `index` is over `points`.
std::vector<LocalSurface> fit_local_surfaces(const Points& points, const CloudIndex& index,
                                             const LocalSurfaceOptions& options = {});

// The fit of one neighbourhood (ids into `points`, at least 6; the first is the point itself, as
// CloudIndex::nearest returns them). Finite on any input; regular = false when it cannot be trusted.
LocalSurface fit_local_surface(const Points& points, const std::vector<int>& neighbourhood);

}  // namespace cmm::geometry
