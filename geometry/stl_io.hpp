// STL, the format CAD systems export for CMM programs: ASCII and binary reading, binary writing.
// STL stores every facet's corners separately, so the reader welds them into shared vertices.
#pragma once

#include <filesystem>
#include <ostream>
#include <string_view>

#include "geometry/mesh_io.hpp"

namespace cmm::geometry {

// `bytes` is the whole file, `file` names it in errors. Facet normals in the file are ignored: the
// winding gives them, and exporters often write zeros there.
ReadResult read_stl(const std::filesystem::path& file, std::string_view bytes);

// Binary, little endian. STL holds float32, so coordinates round to about 1e-7 of their magnitude.
void write_stl(std::ostream& out, const TriangleMesh& mesh);

}  // namespace cmm::geometry
