// Points, directions and rigid transforms in JSON, spelled one way in every file cmmd reads or
// writes: [x, y, z], and a 4×4 matrix as four rows of four numbers (row-major, last row 0 0 0 1).
#pragma once

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

namespace cmm::description {

nlohmann::json vec3_json(const Eigen::Vector3d& v);
nlohmann::json transform_json(const Eigen::Isometry3d& T);

// For cmmd's own files (a journal, a job's registration): std::invalid_argument for anything that
// is not the shape above, naming what was found. Outside input goes through JsonFields instead.
Eigen::Vector3d vec3_from_json(const nlohmann::json& j);
Eigen::Isometry3d transform_from_json(const nlohmann::json& j);

}  // namespace cmm::description
