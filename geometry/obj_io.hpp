// Wavefront OBJ, the lowest common denominator of mesh tools: v, vn and f are read, everything else
// (texture coordinates, groups, materials, smoothing) is ignored; polygons are fan-triangulated.
#pragma once

#include <filesystem>
#include <ostream>
#include <string_view>

#include "geometry/mesh_io.hpp"

namespace cmm::geometry {

// `bytes` is the whole file, `file` names it in errors. Without f lines the file reads as a PointCloud,
// whose normals pair with the v lines in order. A mesh gets vertex normals when every vertex is given
// one by a face corner (f v//n or v/t/n); where corners disagree, the first wins.
ReadResult read_obj(const std::filesystem::path& file, std::string_view bytes);

// v and f lines; with vertex normals also vn lines and f v//n corners.
void write_obj(std::ostream& out, const TriangleMesh& mesh);
// v lines, and vn lines when the cloud has normals.
void write_obj(std::ostream& out, const PointCloud& cloud);

}  // namespace cmm::geometry
