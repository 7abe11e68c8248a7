// Clean-up shared by the mesh readers: welding corners that STL stores once per facet, and dropping
// faces that carry no surface (degenerate) or carry it twice (duplicates). Counts go into the ReadReport.
#pragma once

#include <cstddef>
#include <functional>

#include "geometry/mesh.hpp"
#include "geometry/mesh_io.hpp"

namespace cmm::geometry {

// Both thresholds scale with the bounding-box diagonal d, so they mean the same in mm and in m.
// Welding merges points closer than 1e-6·d, over ten times float32 rounding (STL stores float32), so
// corners an exporter computed twice still meet; on a part with a 1 m diagonal that is 1 µm. A face is
// degenerate when twice its area is at most (1e-6·d)²: on that part, a face 1 mm long must be under
// 1 nm high, so only numerically collinear faces go and real slivers stay.
inline constexpr double relative_tolerance = 1e-6;

// Welds `count` points, read through point(i), all inside the box [low, high]: each point joins an
// earlier kept point within the tolerance, or is kept itself. Returns the kept points in order of first
// appearance and writes each point's kept index to index_of[i]. Taking points through a function lets
// the binary STL reader weld straight from the file, never holding the unwelded corners.
Points weld_points(std::size_t count, const std::function<Vec3(std::size_t)>& point, const Vec3& low, const Vec3& high,
                   int* index_of);

// weld_points on a mesh's vertices: renumbers the faces and removes the merged vertices (and their
// normals, keeping the kept vertex's own).
void weld_vertices(TriangleMesh& mesh, ReadReport& report);

// Drops faces with a repeated index or (near) zero area, then faces with the same three vertices as
// an earlier face in any order; vertices are left alone so file indices stay valid.
void drop_bad_faces(TriangleMesh& mesh, ReadReport& report);

}  // namespace cmm::geometry
