// XYZ, the plainest scanner export: one point per line as "x y z" or "x y z nx ny nz", separated by
// blanks or commas, with '#' comments and blank lines allowed.
#pragma once

#include <filesystem>
#include <ostream>
#include <string_view>

#include "geometry/mesh_io.hpp"

namespace cmm::geometry {

// `bytes` is the whole file, `file` names it in errors. All lines must have as many columns as the first.
ReadResult read_xyz(const std::filesystem::path& file, std::string_view bytes);

// Space-separated, with normals when the cloud has them.
void write_xyz(std::ostream& out, const PointCloud& cloud);

}  // namespace cmm::geometry
