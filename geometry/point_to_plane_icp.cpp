// Point-to-plane ICP: area-sampled source points, nearest target vertex by k-d tree (pairs whose
// normals disagree left out), the 6 × 6 normal equations of the small-angle linearisation, solved
// and re-orthogonalised each iteration.
#include "geometry/point_to_plane_icp.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include "geometry/cloud_index.hpp"
#include "geometry/face_geometry.hpp"

namespace cmm::geometry {

namespace {

Points area_weighted_normals(const TriangleMesh& mesh, const FaceGeometry& faces) {
  Points normals = Points::Zero(mesh.vertices.rows(), 3);
  for (int f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) normals.row(mesh.faces(f, k)) += faces.areas[static_cast<std::size_t>(f)] * faces.normals.row(f);
  for (int v = 0; v < normals.rows(); ++v) {
    const double n = normals.row(v).norm();
    if (n > 0) normals.row(v) /= n;
  }
  return normals;
}

struct Sample {
  Vec3 point;
  Vec3 normal;
};

// Points spread over the faces by area (deterministic for a seed), with their face's normal, plus
// every vertex with its area-weighted normal.
std::vector<Sample> area_samples(const TriangleMesh& mesh, const FaceGeometry& faces, int count, unsigned seed) {
  std::vector<Sample> samples;
  samples.reserve(static_cast<std::size_t>(count) + static_cast<std::size_t>(mesh.vertices.rows()));
  std::vector<double> cumulative(faces.areas.size());
  double total = 0;
  for (std::size_t f = 0; f < faces.areas.size(); ++f) cumulative[f] = total += faces.areas[f];
  if (total > 0) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0, 1);
    for (int i = 0; i < count; ++i) {
      const auto f = static_cast<int>(std::lower_bound(cumulative.begin(), cumulative.end(), unit(rng) * total) -
                                      cumulative.begin());
      const int face = std::min(f, static_cast<int>(cumulative.size()) - 1);
      double a = unit(rng), b = unit(rng);
      if (a + b > 1) a = 1 - a, b = 1 - b;
      const Vec3 p0 = vertex(mesh, mesh.faces(face, 0)), p1 = vertex(mesh, mesh.faces(face, 1)),
                 p2 = vertex(mesh, mesh.faces(face, 2));
      samples.push_back({p0 + a * (p1 - p0) + b * (p2 - p0), faces.normals.row(face).transpose()});
    }
  }
  const Points normals = area_weighted_normals(mesh, faces);
  for (int v = 0; v < mesh.vertices.rows(); ++v) samples.push_back({vertex(mesh, v), normals.row(v).transpose()});
  return samples;
}

}  // namespace

IcpResult point_to_plane_icp(const TriangleMesh& source, const TriangleMesh& target, const Eigen::Isometry3d& initial,
                             const IcpOptions& options) {
  if (source.faces.rows() == 0 || target.vertices.rows() == 0)
    throw std::invalid_argument("point-to-plane ICP: the nominal or the reference mesh is empty");
  const FaceGeometry source_faces = face_geometry(source), target_faces = face_geometry(target);
  const std::vector<Sample> samples = area_samples(source, source_faces, options.samples, options.seed);
  const double min_cos = std::cos(options.max_normal_angle_deg * std::numbers::pi / 180);
  const Points normals = area_weighted_normals(target, target_faces);
  const CloudIndex index(target.vertices);
  // A sample lies up to about one edge length from its nearest target vertex, however well it fits
  // the plane there: pairs are gated by that distance, and rejected by their distance to the plane.
  double edge_sum = 0;
  for (int f = 0; f < target.faces.rows(); ++f)
    edge_sum += (vertex(target, target.faces(f, 0)) - vertex(target, target.faces(f, 1))).norm();
  const double vertex_reach = target.faces.rows() > 0 ? 2 * edge_sum / static_cast<double>(target.faces.rows()) : 0;

  IcpResult result;
  result.T_target_source = initial;
  double reject = options.reject_mm;
  std::vector<int> ids(1);
  std::vector<double> squared(1);
  for (int iteration = 1; iteration <= options.max_iterations; ++iteration) {
    Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
    double sum_squared = 0;
    int pairs = 0;
    for (const Sample& s : samples) {
      const Vec3 p = result.T_target_source * s.point;
      index.nearest(p, 1, ids, squared);
      const double reach = std::max(reject, vertex_reach);
      if (ids.empty() || squared[0] > reach * reach) continue;
      const Vec3 n = normals.row(ids[0]).transpose();
      // A face sample beside a crease finds the crease's vertex, whose normal leans halfway to the
      // other face: its plane would pull the fit off by micrometres, so such pairs are left out.
      if (n.dot(result.T_target_source.linear() * s.normal) < min_cos) continue;
      const double r = n.dot(p - vertex(target, ids[0]));
      if (std::abs(r) > reject) continue;
      Eigen::Matrix<double, 6, 1> J;
      J << p.cross(n), n;
      A += J * J.transpose();
      b -= J * r;
      sum_squared += r * r;
      ++pairs;
    }
    if (pairs < 6) {
      if (iteration == 1)
        throw std::invalid_argument("point-to-plane ICP: no part of the nominal lies within " + std::to_string(reject) +
                                    " mm of the reference from the start; place it roughly first");
      break;
    }
    result.iterations = iteration;
    result.rms_mm = std::sqrt(sum_squared / pairs);
    result.overlap = static_cast<double>(pairs) / static_cast<double>(samples.size());
    const Eigen::Matrix<double, 6, 1> x = A.ldlt().solve(b);
    const Vec3 omega = x.head<3>(), t = x.tail<3>();
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    if (omega.norm() > 0) step.linear() = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
    step.translation() = t;
    result.T_target_source = step * result.T_target_source;
    // The largest move of a sample: rotation about the origin times the farthest sample, plus the shift.
    double reach = 0;
    for (const Sample& s : samples) reach = std::max(reach, (result.T_target_source * s.point).norm());
    reject = std::max(options.min_reject_mm, std::min(reject, 3 * result.rms_mm + options.min_reject_mm));
    if (omega.norm() * reach + t.norm() < options.step_mm) {
      result.converged = true;
      break;
    }
  }
  return result;
}

}  // namespace cmm::geometry
