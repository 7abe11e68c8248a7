// PLY, the format of scanners and mesh tools: ASCII and binary of either byte order, any element layout.
// Vertices (x y z, optional nx ny nz) and faces are read; other elements and properties are skipped.
#pragma once

#include <filesystem>
#include <ostream>
#include <string_view>

#include "geometry/mesh_io.hpp"

namespace cmm::geometry {

enum class PlyEncoding { ascii, binary_little_endian };

// `bytes` is the whole file, `file` names it in errors. Polygons are fan-triangulated; without faces
// (no face element, or 0 faces) the file reads as a PointCloud.
ReadResult read_ply(const std::filesystem::path& file, std::string_view bytes);

// Coordinates and normals as float64, so a round trip is exact and the file adds no error to micrometre
// work on metre-sized parts; faces as uchar-counted int lists. ASCII is for golden files and the eye.
void write_ply(std::ostream& out, const TriangleMesh& mesh, PlyEncoding encoding = PlyEncoding::binary_little_endian);
void write_ply(std::ostream& out, const PointCloud& cloud, PlyEncoding encoding = PlyEncoding::binary_little_endian);

}  // namespace cmm::geometry
