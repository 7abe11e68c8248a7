// The deviation colour map as a picture: a software rasterizer draws the reference mesh, grey and
// Lambert-shaded in an isometric view from above the front, and the measured points on it as
// coloured discs, hidden where the part covers them. For the job report (docs/report.md).
#pragma once

#include <vector>

#include "geometry/mesh.hpp"
#include "planner/png_image.hpp"

namespace cmm::planner {

struct MapPoint {
  geometry::Vec3 position = geometry::Vec3::Zero();  // S, mm (the mesh's frame)
  Rgb colour;
  double radius_px = 4;
};

struct DeviationMapOptions {
  int width = 900, height = 600;
  Rgb background{255, 255, 255};  // white: the report prints on paper
  // The viewer's direction from the part: azimuth from −y (the front) toward +x, elevation above
  // the xy plane, degrees. S has z up, as the part lies on the machine.
  double azimuth_deg = 35, elevation_deg = 30;
};

// Where a point's disc went: its centre pixel, and whether the disc was drawn (off the picture, or
// behind the part as seen from the view, it is not).
struct DrawnPoint {
  int x = -1, y = -1;
  bool visible = false;
};

struct DeviationMap {
  RgbImage image;
  std::vector<DrawnPoint> points;  // one per input point, same order
  int visible = 0;                 // how many were drawn
};

// Orthographic view that fits the mesh and the points with a margin; the mesh may be null (points
// alone, none hidden). Points are drawn in the given order, later ones on top. Throws
// std::invalid_argument for a size that is not positive.
DeviationMap render_deviation_map(const geometry::TriangleMesh* mesh, const std::vector<MapPoint>& points,
                                  const DeviationMapOptions& options = {});

}  // namespace cmm::planner
