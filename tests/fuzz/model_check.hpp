// What every mesh and cloud reader promises of what it accepts (geometry/mesh_io.hpp): finite
// coordinates, faces that index existing vertices, normals one per vertex or none. A broken promise
// is a finding as much as a crash is, since everything downstream indexes by these.
#pragma once

#include <variant>

#include "geometry/mesh_io.hpp"

namespace cmm::fuzz {

inline void check_model(const geometry::ReadResult& result) {
  bool ok = true;
  if (const auto* mesh = std::get_if<geometry::TriangleMesh>(&result.model)) {
    ok = mesh->vertices.allFinite() && (mesh->faces.size() == 0 || (mesh->faces.minCoeff() >= 0 &&
                                                                     mesh->faces.maxCoeff() < mesh->vertices.rows()));
    ok = ok && (mesh->vertex_normals.rows() == 0 || mesh->vertex_normals.rows() == mesh->vertices.rows());
  } else {
    const auto& cloud = std::get<geometry::PointCloud>(result.model);
    ok = cloud.points.allFinite() && (cloud.normals.rows() == 0 || cloud.normals.rows() == cloud.points.rows());
  }
  if (!ok) __builtin_trap();
}

}  // namespace cmm::fuzz
