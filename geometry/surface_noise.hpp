// How far a mesh's vertices lie off the surface they sample, in millimetres, whatever the triangles'
// sizes and shapes: the figure that says whether single facets can be trusted, and that enters δ.
#pragma once

#include <vector>

#include "geometry/edge_adjacency.hpp"
#include "geometry/face_geometry.hpp"

namespace cmm::geometry {

struct SurfaceNoise {
  double sigma_mm = 0;  // robust standard deviation of the vertices' distance from the local surface
  int measured = 0;     // vertices whose neighbourhood could be fitted (a coarse CAD mesh may have none)
  int sampled = 0;      // vertices looked at
  // Per vertex, its scaled distance from the local fit; NaN where it was not measured. The figure above
  // is the mesh's typical vertex; near an edge a decimated mesh's moved vertices may lie much farther.
  std::vector<float> vertex_residual_mm;
};

// Per vertex (every k-th of a big mesh), the side of its faces with the most area (faces joined across
// edges under crease_angle) and the vertices of that side's two rings are fitted with a quadric height
// field, leaving the vertex out; its distance from the fit, scaled by the fit's own uncertainty there,
// is one sample of the noise. A vertex whose side is too small or too degenerate for a quadric (a
// corner of a 12-triangle box, a cone's apex) gives none: its position is all the mesh says of it.
// On an exact mesh of a plane, cylinder, cone or sphere the fit is exact to third order, so the figure
// measures the vertices, not the tessellation.
SurfaceNoise surface_noise(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const FaceGeometry& faces,
                           double crease_angle_rad);

}  // namespace cmm::geometry
