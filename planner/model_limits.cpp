// The model limits: counts first, then the model's extent against the travel box's diagonal.
#include "planner/model_limits.hpp"

#include <algorithm>
#include <vector>

#include "planner/number_text.hpp"

namespace cmm::planner {

namespace {

using geometry::Vec3;

// The vertex farthest from the per-axis median of all vertices: the median stays with the part
// however far a few stray vertices are, so this names the stray one.
Eigen::Index farthest_from_median(const geometry::Points& v, Vec3& median) {
  std::vector<double> column(static_cast<std::size_t>(v.rows()));
  for (int axis = 0; axis < 3; ++axis) {
    for (Eigen::Index i = 0; i < v.rows(); ++i) column[static_cast<std::size_t>(i)] = v(i, axis);
    std::nth_element(column.begin(), column.begin() + static_cast<std::ptrdiff_t>(column.size() / 2), column.end());
    median[axis] = column[column.size() / 2];
  }
  Eigen::Index farthest = 0;
  (v.rowwise() - median.transpose()).rowwise().squaredNorm().maxCoeff(&farthest);
  return farthest;
}

}  // namespace

void check_model_limits(const geometry::TriangleMesh& mesh, const description::TravelBox& travel_box, const std::string& source,
                        const ModelLimits& limits) {
  const auto vertices = static_cast<std::size_t>(mesh.vertices.rows());
  const auto faces = static_cast<std::size_t>(mesh.faces.rows());
  if (vertices > limits.max_vertices)
    throw ModelRefused(source + ": " + std::to_string(vertices) + " vertices, more than the limit of " +
                       std::to_string(limits.max_vertices) + ": decimate the mesh");
  if (faces > limits.max_faces)
    throw ModelRefused(source + ": " + std::to_string(faces) + " triangles, more than the limit of " +
                       std::to_string(limits.max_faces) + ": decimate the mesh");
  if (vertices == 0) return;
  if (!mesh.vertices.allFinite()) throw ModelRefused(source + ": a coordinate is not a finite number");

  const Vec3 lo = mesh.vertices.colwise().minCoeff().transpose();
  const Vec3 hi = mesh.vertices.colwise().maxCoeff().transpose();
  const Vec3 extent = hi - lo;
  const double reach = (travel_box.max - travel_box.min).cwiseMax(0).norm();
  if (extent.maxCoeff() <= reach) return;
  Vec3 median;
  const Eigen::Index far = farthest_from_median(mesh.vertices, median);
  const Vec3 at = mesh.vertices.row(far).transpose();
  throw ModelRefused(source + ": the model spans " + fixed(extent.x(), 1) + " × " + fixed(extent.y(), 1) + " × " +
                     fixed(extent.z(), 1) + " mm, more than the travel box's diagonal of " + fixed(reach, 1) +
                     " mm, so no placement fits it; the farthest vertex is " + std::to_string(far) + " at (" +
                     fixed(at.x(), 3) + ", " + fixed(at.y(), 3) + ", " + fixed(at.z(), 3) + "), " +
                     fixed((at - median).norm(), 1) +
                     " mm from the median of the vertices: a stray vertex, or a model in another unit (scale)?");
}

}  // namespace cmm::planner
