// [x, y, z] and 4×4 row-major arrays to and from Eigen.
#include "hal/description/eigen_json.hpp"

#include <cmath>
#include <stdexcept>

namespace cmm::description {

namespace {
double finite_number(const nlohmann::json& j, const char* what) {
  if (!j.is_number() || !std::isfinite(j.get<double>()))
    throw std::invalid_argument(std::string(what) + ": expected a finite number, not " + j.dump());
  return j.get<double>();
}
}  // namespace

nlohmann::json vec3_json(const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); }

nlohmann::json transform_json(const Eigen::Isometry3d& T) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back(nlohmann::json::array({T(r, 0), T(r, 1), T(r, 2), T(r, 3)}));
  return rows;
}

Eigen::Vector3d vec3_from_json(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 3) throw std::invalid_argument("expected [x, y, z], not " + j.dump());
  return {finite_number(j[0], "x"), finite_number(j[1], "y"), finite_number(j[2], "z")};
}

Eigen::Isometry3d transform_from_json(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 4) throw std::invalid_argument("expected a 4x4 matrix (4 rows), not " + j.dump());
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    const nlohmann::json& row = j[static_cast<std::size_t>(r)];
    if (!row.is_array() || row.size() != 4)
      throw std::invalid_argument("expected a 4x4 matrix, row " + std::to_string(r) + " is " + row.dump());
    for (int c = 0; c < 4; ++c) m(r, c) = finite_number(row[static_cast<std::size_t>(c)], "matrix element");
  }
  if (!m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)))
    throw std::invalid_argument("expected a rigid transform: the last row must be 0 0 0 1");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix() = m;
  return T;
}

}  // namespace cmm::description
