// Deterministic: std::mt19937_64 with fixed seeds and no distribution whose output the standard
// leaves to the library (the normal deviates come from Box–Muller on uniform draws).
#include "scan_samples.hpp"

#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <tuple>
#include <vector>

namespace cmm::geometry::testing {
namespace {

double uniform(std::mt19937_64& rng) { return (rng() >> 11) * (1.0 / 9007199254740992.0); }

double gaussian(std::mt19937_64& rng) {
  const double u = std::max(uniform(rng), 1e-300), v = uniform(rng);
  return std::sqrt(-2 * std::log(u)) * std::cos(2 * std::numbers::pi * v);
}

}  // namespace

PointCloud sample_faces(const TriangleMesh& mesh, double spacing, double sigma, std::uint64_t seed,
                        const std::function<bool(const Vec3&, const Vec3&)>& keep) {
  std::mt19937_64 rng(seed);
  std::vector<Vec3> points, normals;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Vec3 a = vertex(mesh, mesh.faces(f, 0)), b = vertex(mesh, mesh.faces(f, 1)), c = vertex(mesh, mesh.faces(f, 2));
    const Vec3 n2 = (b - a).cross(c - a);
    const Vec3 n = n2.normalized();
    if (keep && !keep(n, (a + b + c) / 3)) continue;
    const double expected = 0.5 * n2.norm() / (spacing * spacing);
    const int count = static_cast<int>(std::floor(expected + uniform(rng)));
    for (int i = 0; i < count; ++i) {
      double s = uniform(rng), t = uniform(rng);
      if (s + t > 1) s = 1 - s, t = 1 - t;
      Vec3 p = a + s * (b - a) + t * (c - a);
      if (sigma > 0) p += sigma * gaussian(rng) * n;
      points.push_back(p);
      normals.push_back(n);
    }
  }
  PointCloud cloud;
  cloud.points.resize(static_cast<Eigen::Index>(points.size()), 3);
  cloud.normals.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t i = 0; i < points.size(); ++i) {
    cloud.points.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
    cloud.normals.row(static_cast<Eigen::Index>(i)) = normals[i].transpose();
  }
  return cloud;
}

Points voxel_thin(const Points& points, double bin) {
  std::map<std::tuple<long, long, long>, std::pair<double, Eigen::Index>> best;
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    const Vec3 q = points.row(i).transpose() / bin;
    const Vec3 c = q.array().floor();
    const double d = (q - c - Vec3::Constant(0.5)).squaredNorm();
    const auto key = std::make_tuple(long(c.x()), long(c.y()), long(c.z()));
    auto [it, inserted] = best.try_emplace(key, d, i);
    if (!inserted && d < it->second.first) it->second = {d, i};
  }
  Points out(static_cast<Eigen::Index>(best.size()), 3);
  Eigen::Index r = 0;
  for (const auto& [key, v] : best) out.row(r++) = points.row(v.second);
  return out;
}

TriangleMesh rectangle(double w, double h) {
  TriangleMesh m;
  m.vertices.resize(4, 3);
  m.vertices << 0, 0, 0, w, 0, 0, w, h, 0, 0, h, 0;
  m.faces.resize(2, 3);
  m.faces << 0, 1, 2, 0, 2, 3;
  return m;
}

}  // namespace cmm::geometry::testing
