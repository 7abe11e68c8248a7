// A hole found on the mesh: a circular open boundary (the scan lost the bore wall) or, on a closed
// mesh, a bore whose rims are circular sharp-edge loops. Its rim points are EdgePoints.
#pragma once

#include <optional>
#include <vector>

#include "geometry/edge_point.hpp"
#include "geometry/mesh.hpp"

namespace cmm::geometry {

enum class HoleSource { open_boundary, bore };

const char* to_string(HoleSource source);


struct Hole {
  int id = 0;
  HoleSource source = HoleSource::bore;
  Vec3 centre = Vec3::Zero();   // centre of the entry rim's best-fit circle
  Vec3 axis = Vec3::UnitZ();    // unit, out of the material at the entry rim
  double radius = 0;
  double perimeter = 0;         // of the entry rim
  double roundness_mm = 0;      // peak-to-valley radial deviation of the entry rim
  std::optional<double> depth;  // wall length along the axis, when the wall is in the mesh
  std::vector<int> rim_point_ids;
};

// A rim point's side normals lie in its hole's meridian plane (the hole is a surface of
// revolution), and the circle fitted to the whole rim knows that plane far better than the few
// noisy facets beside one point: projects the normals into the meridian plane through the point's
// position and sets its tangent across it. The probe's cross-section plane then contains the
// hole's axis, as the two-touch compensation assumes, wherever along the rim the point sits.
void align_to_hole(EdgePoint& point, const Hole& hole);

}  // namespace cmm::geometry
