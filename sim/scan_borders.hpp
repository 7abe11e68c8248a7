// The borders of what a synthesized scan saw: the boundary loops of the true part's faces that some
// view sees. A mesh made from the scan should have exactly these openings (the unseen underside, a
// bore's unseen depth) and no others; the tests and `cmm-scan --truth` report them.
#pragma once

#include <vector>

#include "geometry/boundary_loops.hpp"
#include "geometry/mesh.hpp"
#include "sim/scan_views.hpp"
#include "sim/view_coverage.hpp"
#include "sim/visibility.hpp"

namespace cmm::sim {

struct ScanBorder {
  geometry::Vec3 centre;        // the loop's centre by length (geometry::loop_centre), scene frame
  double perimeter_mm = 0;
  geometry::LoopKind kind = geometry::LoopKind::outer;
  geometry::Vec3 surface_normal;  // of the seen surface next to the border
  std::vector<geometry::Vec3> points;  // the border's corners in order, scene frame
  // How wide the unseen region beyond the border and the seen one within it are: the largest distance
  // from one of the region's face centroids to the nearest on the other side (half a strip's width, a
  // round patch's radius). A scan's mesh closes an unseen region no wider than its gap rule's reach
  // (docs/scan.md, "Gap or opening") and has no piece for a seen speck narrower than a bin or two.
  double unseen_half_width_mm = 0;
  double seen_half_width_mm = 0;
  // A hole border's mouth: the radius of the widest disc inside the loop seen down `mouth_axis` (a
  // bore's or slot's axis, across the normals of the seen wall along the border; the face's normal round
  // a pinhole; its sign arbitrary). Through a hole the unseen region runs on down the walls and over the
  // underside, but what the scan shows is a void as wide as the mouth (a Ø3 hole's 1.5 mm, a 2 mm slot's
  // 1 mm). 0 for outer borders and for a loop that does not go round its axis.
  double mouth_half_width_mm = 0;
  geometry::Vec3 mouth_axis = geometry::Vec3::Zero();
};

// A face counts as seen when some view sees its centroid (within the view's coverage band, when given:
// RawScanTruth::coverage, one per view): the synthesis samples faces area-uniformly, so a seen face of
// any size has points, and a face half in shadow or cut by a band's edge is split by the border anyway.
std::vector<ScanBorder> scan_borders(const geometry::TriangleMesh& scene, const std::vector<ScanView>& views,
                                     double max_incidence_deg = kDefaultMaxIncidenceDeg,
                                     const std::vector<CoverageBand>& coverage = {});

}  // namespace cmm::sim
