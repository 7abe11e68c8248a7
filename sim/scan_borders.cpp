// Seen faces by centroid visibility, then their boundary loops; see scan_borders.hpp.
#include "sim/scan_borders.hpp"

#include <stdexcept>

#include "geometry/edge_adjacency.hpp"

namespace cmm::sim {

std::vector<ScanBorder> scan_borders(const geometry::TriangleMesh& scene, const std::vector<ScanView>& views,
                                     double max_incidence_deg, const std::vector<CoverageBand>& coverage) {
  if (!coverage.empty() && coverage.size() != views.size())
    throw std::invalid_argument("scan borders: one coverage band per view, or none");
  const ScanVisibility visibility(scene, max_incidence_deg);
  geometry::TriangleMesh seen{scene.vertices, geometry::Triangles(scene.faces.rows(), 3), {}};
  Eigen::Index kept = 0;
  for (Eigen::Index f = 0; f < scene.faces.rows(); ++f) {
    geometry::Vec3 centroid = geometry::Vec3::Zero();
    for (int k = 0; k < 3; ++k) centroid += geometry::vertex(scene, scene.faces(f, k));
    centroid /= 3;
    for (std::size_t v = 0; v < views.size(); ++v)
      if ((coverage.empty() || coverage[v].keeps(centroid)) &&
          visibility.sees(centroid, static_cast<int>(f), views[v].direction)) {
        seen.faces.row(kept++) = scene.faces.row(f);
        break;
      }
  }
  seen.faces.conservativeResize(kept, 3);
  std::vector<ScanBorder> borders;
  for (const geometry::BoundaryLoop& loop : geometry::boundary_loops(seen, geometry::edge_adjacency(seen))) {
    ScanBorder border;
    border.centre = geometry::Vec3::Zero();
    for (int v : loop.vertices) border.centre += geometry::vertex(seen, v);
    border.centre /= static_cast<double>(loop.vertices.size());
    border.perimeter_mm = loop.perimeter;
    border.kind = loop.kind;
    border.surface_normal = loop.surface_normal;
    borders.push_back(border);
  }
  return borders;
}

}  // namespace cmm::sim
