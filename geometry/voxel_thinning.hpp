// Voxel-bin thinning (thesis §3.4): one real point per occupied cubic bin, the one nearest the bin's
// centre; uniform at the bin size B, or adaptive, with bins of B·2^l that follow the local curvature.
#pragma once

#include <vector>

#include "geometry/cancellation.hpp"
#include "geometry/cloud_index.hpp"
#include "geometry/local_surface.hpp"
#include "geometry/mesh.hpp"

namespace cmm::geometry {

// Indices into `points` of the kept points, ascending. Bins are aligned to the cloud's bounding-box
// minimum and keyed by three 64-bit integers (no packed index to overflow: PCL's VoxelGrid's 32-bit
// one does at ~1,300 bins per axis); ties go to the lower index. Linear time (hashing). Throws
// std::invalid_argument on a bin that is not positive and finite, non-finite coordinates, or more
// than 2⁶² bins along an axis.
std::vector<int> thin_uniform(const Points& points, double bin_mm, const CancelCheck& cancel = {});

struct AdaptiveThinningOptions {
  double bin_mm = 1;           // B: the finest bin (ε's on the most curved region)
  double tolerance_mm = 0.05;  // ε: the coarsest bin a point allows is Ω/√3 of its own curvature
  // Bins reach B·2^max_level on flat faces (4·B at 2): coarser, and a face's edges lose their points
  // for the triangulation.
  int max_level = 2;
  CancelCheck cancel;
};

// Bins of B·2^l, l = 0…max_level, on nested aligned grids (an octree cut at max_level). Each point
// asks for the level its own fit allows at ε (|k1| + one standard error, so noise errs finer;
// irregular points — creases, corners — ask for B); a bin of level l is used when every point in it
// allows l and every point in its 26 neighbours at that level allows l − 1 (so neighbouring regions
// differ by about one level at most); else its eight children are tried. Never coarser than ε allows
// at any point in the bin, never finer than B. `fits` are of `points`.
struct AdaptiveThinning {
  std::vector<int> kept;    // ascending indices into `points`
  std::vector<int> levels;  // per kept point: the level l of its bin (B·2^l)
};

AdaptiveThinning thin_adaptive(const Points& points, const std::vector<LocalSurface>& fits,
                               const AdaptiveThinningOptions& options);

}  // namespace cmm::geometry
