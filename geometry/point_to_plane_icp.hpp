// Best fit of one surface onto another by point-to-plane ICP (Chen and Medioni 1992, linearised as in
// Low 2004): places a nominal (CAD) model onto the scan a job measured, when it is not given in place.
#pragma once

#include <Eigen/Geometry>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct IcpOptions {
  int max_iterations = 60;
  // Pairs farther from the target's plane than this are not the same surface (the scan saw less than
  // the model has); it shrinks to 3 × the RMS of the pairs each iteration, never below min_reject_mm.
  // A pair's sample and vertex may be farther apart, up to twice the target's mean edge length.
  double reject_mm = 5.0;
  double min_reject_mm = 0.05;
  // A pair whose normals differ by more than this is not the same surface: a sample beside a crease
  // and the crease's vertex, or the two sides of a thin wall.
  double max_normal_angle_deg = 20;
  // Converged when an iteration moves no sample by more than this.
  double step_mm = 1e-6;
  int samples = 20000;  // taken over the source's area, so a CAD export's few huge facets count by area
  unsigned seed = 1;
};

struct IcpResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  int iterations = 0;
  bool converged = false;
  double rms_mm = 0;   // point-to-plane, of the pairs kept in the last iteration
  double overlap = 0;  // share of the samples paired within the rejection distance at the end
};

// Fits `source` onto `target` from `initial` (T_target_source). The target's vertices and their
// area-weighted normals are the planes; its vertices should be denser than the fit's accuracy needs
// (a scan's mesh is). Throws std::invalid_argument when either mesh is empty, or when no pair lies
// within reject_mm of the start (the start is too far off for a local fit).
IcpResult point_to_plane_icp(const TriangleMesh& source, const TriangleMesh& target,
                             const Eigen::Isometry3d& initial = Eigen::Isometry3d::Identity(),
                             const IcpOptions& options = {});

}  // namespace cmm::geometry
