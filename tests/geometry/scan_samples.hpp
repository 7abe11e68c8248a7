// Test support for the scan front end: raw clouds sampled on a part's faces (area-uniform, optional
// noise along the normal) and the one-point-per-bin thinning the triangulation expects.
#pragma once

#include <cstdint>
#include <functional>

#include "geometry/mesh.hpp"
#include "geometry/point_cloud.hpp"

namespace cmm::geometry::testing {

// About area / spacing² points per face (of the faces `keep` accepts, given the face's unit outward
// normal and centroid), each moved by N(0, sigma) along its face's normal, with that normal. Same seed,
// same cloud.
PointCloud sample_faces(const TriangleMesh& mesh, double spacing, double sigma, std::uint64_t seed,
                        const std::function<bool(const Vec3& normal, const Vec3& centroid)>& keep = {});

// One point per cubic bin of side `bin`: the one nearest the bin's centre (thesis §3.4), in bin order.
Points voxel_thin(const Points& points, double bin);

// A mesh of the rectangle [0, w] × [0, h] at z = 0, normal +z, as two triangles.
TriangleMesh rectangle(double w, double h);

}  // namespace cmm::geometry::testing
