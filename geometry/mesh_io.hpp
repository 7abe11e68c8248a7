// Reading and writing models by file extension: .stl, .ply, .obj, .off (meshes) and .xyz (clouds).
// A file without faces reads as a PointCloud; every failure is a FileError naming file and line/byte.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <variant>
#include <vector>

#include "geometry/mesh.hpp"
#include "geometry/point_cloud.hpp"

namespace cmm::geometry {

// What the reader changed on the way in, so callers can report it instead of hiding it.
struct ReadReport {
  std::size_t vertices_read = 0;              // as stored in the file (STL: 3 per facet)
  std::size_t faces_read = 0;                 // triangles after fan-triangulating polygons
  std::size_t vertices_welded = 0;            // vertices merged into another (STL, duplicates)
  std::size_t degenerate_faces_dropped = 0;   // repeated index or zero area
  std::size_t duplicate_faces_dropped = 0;    // same three vertices as an earlier face
  std::size_t polygons_triangulated = 0;      // faces with more than three corners
  std::size_t points_without_return = 0;      // PCD organized cloud: NaN pixels dropped (not in vertices_read)
  bool viewpoint_applied = false;             // PCD: the points were moved by a VIEWPOINT that is not the identity
};

using Model = std::variant<TriangleMesh, PointCloud>;

struct ReadResult {
  Model model;
  ReadReport report;
};

// The extensions read_model knows (lower case, with the dot: ".stl", ".ply", ...), in one list, for
// those that accept model files before reading them (cmmd's model.upload).
std::vector<std::string> model_extensions();

ReadResult read_model(const std::filesystem::path& file);
// Throws FileError when the file holds a cloud rather than a mesh.
TriangleMesh read_mesh(const std::filesystem::path& file, ReadReport* report = nullptr);

// Format from the extension; PLY and STL are written binary (little endian), PCD binary float32 (what
// PCL's tools read; geometry/pcd_io.hpp writes float64 too), .asc as XYZ.
void write_mesh(const std::filesystem::path& file, const TriangleMesh& mesh);
void write_cloud(const std::filesystem::path& file, const PointCloud& cloud);

}  // namespace cmm::geometry
