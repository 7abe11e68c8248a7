// Which surface points a scanner view sees: turned toward it within the incidence limit and not hidden
// behind another face. This is what makes a synthesized scan lose steep faces and the walls of bores.
#pragma once

#include "geometry/face_geometry.hpp"
#include "geometry/mesh.hpp"
#include "geometry/triangle_bvh.hpp"

namespace cmm::sim {

// Beyond this angle between the beam and the surface normal a laser scanner gets too little light back.
inline constexpr double kDefaultMaxIncidenceDeg = 75;

// Builds its tree once; every query after that is const.
class ScanVisibility {
 public:
  // Keeps its own copy of the scene. Throws std::invalid_argument for a max_incidence_deg outside
  // (0, 90) or a scene coordinate that is not finite.
  explicit ScanVisibility(const geometry::TriangleMesh& scene, double max_incidence_deg = kDefaultMaxIncidenceDeg);

  // Whether `face` turns its outside toward a view along `view_direction` (unit, scanner → part) at an
  // incidence below the limit. A degenerate face never does.
  bool facing(int face, const geometry::Vec3& view_direction) const;
  // Whether the beam from `point` (on `face`) back toward the scanner, along −view_direction, hits
  // another part of the scene first.
  bool occluded(const geometry::Vec3& point, int face, const geometry::Vec3& view_direction) const;
  bool sees(const geometry::Vec3& point, int face, const geometry::Vec3& view_direction) const {
    return facing(face, view_direction) && !occluded(point, face, view_direction);
  }

  const geometry::TriangleMesh& scene() const { return scene_; }
  const geometry::FaceGeometry& face_geometry() const { return faces_; }

 private:
  geometry::TriangleMesh scene_;
  geometry::FaceGeometry faces_;
  geometry::TriangleBvh tree_;
  double cos_limit_;
  double self_hit_;  // mm: hits nearer than this are the beam leaving its own surface, not an occluder
};

}  // namespace cmm::sim
