// OFF (Geomview's Object File Format), common for research meshes such as CGAL's: a header word, the
// counts, one line per vertex, one per face. The NOFF, COFF and CNOFF variants are read as well.
#pragma once

#include <filesystem>
#include <ostream>
#include <string_view>

#include "geometry/mesh_io.hpp"

namespace cmm::geometry {

// `bytes` is the whole file, `file` names it in errors. Polygons are fan-triangulated, colours ignored;
// with 0 faces the file reads as a PointCloud.
ReadResult read_off(const std::filesystem::path& file, std::string_view bytes);

// OFF, or NOFF when there are normals; a cloud is written with 0 faces.
void write_off(std::ostream& out, const TriangleMesh& mesh);
void write_off(std::ostream& out, const PointCloud& cloud);

}  // namespace cmm::geometry
