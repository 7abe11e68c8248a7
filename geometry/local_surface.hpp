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
  Vec3 normal = Vec3::UnitZ();  // unit; PCA's least-variance axis, sign not yet oriented
  Vec3 u = Vec3::UnitX(), v = Vec3::UnitY();  // tangent frame, u × v = normal
  double a = 0, b = 0, c = 0;                  // S(u,v) along `normal`, mm⁻¹
  double k1 = 0, k2 = 0;                       // principal curvatures at the origin, |k1| ≥ |k2|, 1/mm
  double curvature_sigma = 0;                  // standard error of k1 from the fit's residual, 1/mm
  double residual_rms_mm = 0;                  // RMS distance of the neighbours from the quadric
  double plane_spread = 0;                     // sqrt(λ_min / λ_mid) of the PCA: 0 on a plane
  double radius_mm = 0;                        // distance from the point to its k-th neighbour
  // False on a crease, a corner, an outlier or a too-thin neighbourhood (fit residual and normal
  // spread tell them): such points say nothing about the smooth surface's curvature.
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

// The fit of one neighbourhood (ids into `points`, at least 6).
LocalSurface fit_local_surface(const Points& points, const std::vector<int>& neighbourhood);

}  // namespace cmm::geometry
